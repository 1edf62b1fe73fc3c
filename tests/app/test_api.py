"""The HTTP API against a real worker (real time) and a temporary SQLite database."""

from __future__ import annotations

import time

import numpy as np
import pytest


def wait_until(predicate, timeout: float = 30.0, interval: float = 0.05):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    raise AssertionError("condition not met in time")


def plan_state(client) -> dict | None:
    return client.get("/api/state").json()["plan"]


def test_health_reports_the_control_loop(client) -> None:
    body = wait_until(lambda: (b := client.get("/api/health").json())["control"]["ticks"] > 0 and b)
    assert body["status"] == "ok" and body["mode"] == "idle"
    assert body["control"]["control_hz"] == 100.0
    assert body["session_id"] >= 1


def test_config_names_places_and_objects(client) -> None:
    body = client.get("/api/config").json()
    assert body["places"] == ["kitchen counter", "living-room table", "charging dock"]
    assert set(body["objects"]) == {"red mug", "blue bottle", "green apple"}
    assert body["physics_hz"] == pytest.approx(500.0)


def test_openapi_lists_the_endpoints(client) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    for path in (
        "/api/health",
        "/api/commands",
        "/api/estop",
        "/api/estop/reset",
        "/api/replan",
        "/api/sessions",
        "/api/sessions/{session_id}",
        "/api/teleop",
        "/api/teleop/stop",
        "/api/posture",
        "/api/reset",
    ):
        assert path in paths


def test_command_is_planned_and_executed(client) -> None:
    response = client.post("/api/commands", json={"text": "say hello operator"})
    assert response.status_code == 202
    assert response.json()["plan"] == {"steps": [{"action": "say", "args": {"text": "hello operator"}}]}
    plan = wait_until(lambda: (p := plan_state(client)) and p["state"] == "succeeded" and p)
    assert plan["steps"][0]["state"] == "succeeded"


def test_a_command_with_two_close_readings_gets_a_question_not_a_plan(client) -> None:
    before = plan_state(client)
    response = client.post("/api/commands", json={"text": "could you bring me the blue mug"})
    assert response.status_code == 422
    detail = response.json()["detail"]
    assert detail["clarify"] == "Did you mean the red mug or the blue bottle?" and detail["plan"] is None
    assert plan_state(client) == before
    answered = client.post("/api/commands", json={"text": "the red one"})  # the answer: that command, so read
    assert answered.status_code == 202
    assert [s["args"] for s in answered.json()["plan"]["steps"]][2] == {"object": "red mug"}
    client.post("/api/plan/cancel")
    accepted = client.post("/api/commands", json={"text": "hey robot, tell everyone that the tea is ready"})
    assert accepted.status_code == 202 and accepted.json()["clarify"] is None
    assert accepted.json()["plan"]["steps"] == [{"action": "say", "args": {"text": "the tea is ready"}}]


def test_a_step_the_robot_cannot_do_is_reported_not_faked(client) -> None:
    steps = [{"action": "pick_object", "args": {"object": "red mug"}}, {"action": "say", "args": {"text": "got it"}}]
    assert client.post("/api/commands", json={"plan": {"steps": steps}}).status_code == 202
    plan = wait_until(lambda: (p := plan_state(client)) and p["state"] == "failed" and p)
    # this test worker runs without its camera: picking says why it cannot
    assert plan["steps"][0]["state"] == "failed" and "perception is off" in plan["steps"][0]["detail"]
    assert plan["steps"][1]["state"] == "skipped"


@pytest.mark.parametrize(
    ("body", "status", "fragment"),
    [
        ({"text": "pick up the purple elephant"}, 422, "unknown object 'purple elephant'"),
        ({"text": "fly to the moon"}, 422, "I don't understand"),
        ({"plan": {"steps": [{"action": "teleport", "args": {"target": "x"}}]}}, 422, "unknown action 'teleport'"),
        ({"plan": {"steps": [{"action": "navigate_to", "args": {"target": "attic"}}]}}, 422, "unknown place"),
        ({"text": "x" * 501}, 422, "at most 500 characters"),
        ({"text": "say hi", "speed": 9}, 422, "Extra inputs are not permitted"),
        ({"text": 42}, 422, "valid string"),
    ],
)
def test_bad_commands_get_a_clear_4xx_and_change_nothing(client, body, status: int, fragment: str) -> None:
    before = plan_state(client)
    response = client.post("/api/commands", json=body)
    assert response.status_code == status
    assert fragment in response.text
    assert plan_state(client) == before


def test_malformed_and_oversized_bodies_are_refused(client) -> None:
    response = client.post("/api/commands", content=b"{not json", headers={"Content-Type": "application/json"})
    assert response.status_code == 422
    huge = b'{"text": "' + b"a" * 100_000 + b'"}'
    response = client.post("/api/commands", content=huge, headers={"Content-Type": "application/json"})
    assert response.status_code == 413
    assert "larger than" in response.json()["detail"]


def test_estop_latches_refuses_commands_and_release_is_explicit(client) -> None:
    assert client.post("/api/estop", json={"source": "test"}).status_code == 200
    state = wait_until(lambda: (s := client.get("/api/state").json())["estop_latched"] and s)
    assert state["mode"] == "estop"

    refused = client.post("/api/commands", json={"text": "say hello"})
    assert refused.status_code == 409
    assert refused.json()["detail"]["refusal"] == "estop_latched"
    assert client.post("/api/replan").status_code == 409

    assert client.post("/api/estop/reset").status_code == 200
    assert client.post("/api/estop/reset").status_code == 409  # not latched any more
    time.sleep(0.2)
    assert client.get("/api/state").json()["mode"] == "idle"  # release restarted nothing
    assert client.post("/api/commands", json={"text": "say back to work"}).status_code == 202


def test_estop_rejects_non_finite_client_time(client) -> None:
    response = client.post(
        "/api/estop", content=b'{"client_time_s": NaN}', headers={"Content-Type": "application/json"}
    )
    assert response.status_code == 422
    assert not client.get("/api/state").json()["estop_latched"]


def test_replan_after_estop_resumes_the_current_command(client) -> None:
    client.post("/api/commands", json={"text": "say a sentence long enough to be interrupted by the e-stop"})
    wait_until(lambda: client.get("/api/state").json()["mode"] == "executing")
    client.post("/api/estop")
    cancelled = wait_until(lambda: (p := plan_state(client)) and p["state"] == "cancelled" and p)
    client.post("/api/estop/reset")
    response = client.post("/api/replan")
    assert response.status_code == 202
    plan = wait_until(lambda: (p := plan_state(client)) and p["revision"] == 2 and p["state"] == "succeeded" and p)
    assert plan["command_id"] == cancelled["command_id"]


def test_sessions_record_commands_plans_steps_and_events(client) -> None:
    client.post("/api/commands", json={"text": "say recorded"})
    wait_until(lambda: (p := plan_state(client)) and p["state"] == "succeeded")
    client.post("/api/commands", json={"text": "pick up the purple elephant"})
    client.post("/api/estop")
    session_id = client.get("/api/health").json()["session_id"]

    def recorded():
        detail = client.get(f"/api/sessions/{session_id}").json()
        kinds = {e["kind"] for e in detail["events"]}
        return (
            {"worker/started", "control/priority", "plan/finished", "estop/latched"} <= kinds
            and detail["telemetry"]["samples"] > 0
            and detail
        )

    detail = wait_until(recorded)
    assert [(c["text"], c["accepted"]) for c in detail["commands"]] == [
        ("say recorded", True),
        ("pick up the purple elephant", False),
    ]
    assert "purple elephant" in detail["commands"][1]["errors"][0]
    assert detail["plans"][0]["plan"]["steps"][0]["action"] == "say"
    assert detail["plans"][0]["state"] == "succeeded"
    assert detail["plans"][0]["steps"][0]["state"] == "succeeded"

    listing = client.get("/api/sessions").json()
    assert listing["total"] >= 1
    assert listing["items"][0]["id"] == session_id
    assert listing["items"][0]["estop_count"] == 1
    assert client.get("/api/sessions/999999").status_code == 404
    assert client.get("/api/sessions?limit=0").status_code == 422


def test_pages_are_served(client) -> None:
    page = client.get("/")
    assert page.status_code == 200 and 'id="estop"' in page.text
    assert client.get("/sessions").status_code == 200
    assert client.get("/static/js/app.js").status_code == 200


def test_health_says_when_the_worker_is_down(client) -> None:
    client.runtime.worker.stop()
    response = client.get("/api/health")
    assert response.status_code == 503
    assert response.json()["status"] == "worker_down"


def test_teleop_posture_and_reset_endpoints(client) -> None:
    assert client.post("/api/teleop", json={"vx": "nan"}).status_code == 422
    assert client.post("/api/teleop", json={"vx": 0.1, "spin": 1}).status_code == 422
    assert client.post("/api/teleop", json={"vx": 1e6}).status_code == 422  # absurd: refused, not clipped
    assert client.post("/api/teleop", json={"yaw_rate": -40.0}).status_code == 422
    reply = client.post("/api/teleop", json={"vx": 0.1, "source": "test"})
    assert reply.status_code == 200 and reply.json()["accepted"]
    worker = client.runtime.worker
    # the published state must show teleop before "idle" below can mean it ended (not a state from before it began)
    assert worker.wait_for(lambda s: s.mode.value == "teleop", 30.0)
    busy = client.post("/api/commands", json={"text": "say hello"})
    assert busy.status_code == 409 and "teleop is active" in busy.json()["detail"]["message"]
    assert client.post("/api/posture", json={"posture": "crouch"}).status_code == 409
    assert client.post("/api/teleop/stop").json()["accepted"]
    # teleop ends at once; the walk takes its last steps (a posture change is refused until it stands)
    assert worker.wait_for(lambda s: s.mode.value == "idle" and s.locomotion.phase == "standing", 30.0)
    assert client.post("/api/posture", json={"posture": "sit"}).status_code == 422
    assert client.post("/api/posture", json={"posture": "crouch"}).status_code == 200
    assert worker.wait_for(lambda s: s.locomotion.posture == "crouch", 30.0)
    assert client.post("/api/reset").status_code == 200
    assert worker.wait_for(lambda s: s.locomotion.posture == "stand" and not s.fallen, 30.0)
    state = client.get("/api/state").json()
    assert state["locomotion"]["phase"] == "standing" and state["mode"] == "idle"


def _wait_plan(client, predicate, timeout_s: float = 30.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        plan = client.get("/api/state").json()["plan"]
        if plan is not None and predicate(plan):
            return plan
        time.sleep(0.05)
    raise AssertionError(f"plan state not reached: {client.get('/api/state').json()['plan']}")


def test_a_command_sent_with_the_recognisers_other_wordings_asks_before_running_one(client) -> None:
    heard = {"text": "say hallo wold", "source": "spoken", "alternatives": ["sea hello world", "say hello world"]}
    unread = {"text": "please grant me the apple", "alternatives": ["please bring me the apple"]}
    queued = client.post("/api/commands", json=unread)
    assert queued.status_code == 202 and queued.json()["message"].startswith('did you mean "please bring me the apple"')
    plan = _wait_plan(client, lambda p: p["state"] == "awaiting_approval")
    assert plan["command_text"] == "please bring me the apple"
    assert client.post("/api/plan/cancel").status_code == 200
    assert client.post("/api/commands", json=heard).status_code == 202  # readable as heard: said, unasked
    _wait_plan(client, lambda p: p["state"] == "succeeded" and p["command_text"] == "say hallo wold")
    # as many other wordings as a transcript carries are taken; more are refused before anything is planned
    from robot.speech.asr import ALTERNATIVES_KEPT

    most = {"text": "grant me the apple", "alternatives": ["x"] * (ALTERNATIVES_KEPT - 1) + ["grab me the apple"]}
    assert client.post("/api/commands", json=most).status_code == 202
    assert client.post("/api/plan/cancel").status_code == 200
    too_many = {"text": "grant me the apple", "alternatives": ["x"] * (ALTERNATIVES_KEPT + 1)}
    refused = client.post("/api/commands", json=too_many)
    assert refused.status_code == 422 and refused.json()["detail"][0]["loc"][-1] == "alternatives", refused.text


def test_plans_can_wait_for_approval_be_approved_paused_and_resumed(client) -> None:
    assert client.put("/api/plan/approval", json={"required": True}).status_code == 200
    # answered once the robot's state says so: what is read next shows the change
    assert client.get("/api/config").json()["approval_required"] is True
    assert client.get("/api/state").json()["approval_required"] is True
    queued = client.post("/api/commands", json={"text": "say hello"}).json()
    assert "awaits approval" in queued["message"]
    plan_id = _wait_plan(client, lambda p: p["state"] == "awaiting_approval")["plan_id"]
    assert client.post("/api/plan/approve", json={"plan_id": plan_id + 5}).status_code == 422
    assert client.post("/api/plan/approve", json={"plan_id": plan_id}).status_code == 200
    assert client.post("/api/plan/approve").status_code == 409
    _wait_plan(client, lambda p: p["state"] == "succeeded")
    assert client.put("/api/plan/approval", json={"required": False}).status_code == 200
    assert client.get("/api/config").json()["approval_required"] is False
    assert client.post("/api/plan/resume").status_code == 409
    assert client.post("/api/commands", json={"plan": [{"action": "wait", "seconds": 3}]}).status_code == 202
    _wait_plan(client, lambda p: p["steps"][0]["state"] == "running" and p["steps"][0]["action"] == "wait")
    assert client.post("/api/plan/pause").status_code == 200
    _wait_plan(client, lambda p: p["state"] == "paused")
    assert client.post("/api/plan/resume").status_code == 200
    _wait_plan(client, lambda p: p["state"] == "running")
    assert client.post("/api/commands", json={"command_id": 1}).status_code == 422  # an edit needs its plan


def test_config_says_which_planner_plans(client) -> None:
    config = client.get("/api/config").json()
    assert config["planner_backend"] == "rules" and config["planner"].startswith("rules")


def test_speech_is_transcribed_from_wav_or_raw_pcm_and_bad_audio_is_refused(client) -> None:
    from robot.speech.audio import read_wav_bytes
    from robot.speech.tts import synthesize, synthesize_audio

    wav = synthesize("go to the charging dock", "en-us", 160)
    heard = client.post("/api/speech/transcribe", content=wav, headers={"Content-Type": "audio/wav"}).json()
    assert heard["text"] == "go to the charging dock" and heard["in_grammar"] is True
    assert set(heard) >= {"confidence", "engine", "audio_s", "decode_ms", "auto_run", "alternatives", "unsure_names"}
    assert heard["first_heard"] == ""  # what it heard first is a command: not read as another
    pcm = synthesize_audio("find the green apple", "en-us", 160).pcm()
    raw = client.post("/api/speech/transcribe", content=pcm, headers={"Content-Type": "audio/L16; rate=16000"})
    assert raw.json()["text"] == "find the green apple"
    assert client.post("/api/speech/transcribe", content=b"not audio").status_code == 422
    short = client.post("/api/speech/transcribe", content=pcm[:3200], headers={"Content-Type": "audio/L16; rate=16000"})
    assert short.status_code == 422 and "shorter than 0.2 s" in short.json()["detail"]["message"]
    odd = client.post("/api/speech/transcribe", content=pcm[:3201], headers={"Content-Type": "audio/L16; rate=16000"})
    assert odd.status_code == 422
    assert client.post("/api/speech/transcribe", content=b"\0" * (1024 * 1024 + 2)).status_code == 413
    assert client.post("/api/commands", content=b"x" * (65 * 1024)).status_code == 413  # other routes keep 64 KiB

    # every transcript is kept with the session, its recording too
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:  # the recorder writes in batches
        kept = client.get(f"/api/sessions/{client.runtime.recorder.session_id}").json()["transcripts"]
        if len(kept) == 2:
            break
        time.sleep(0.1)
    assert [t["text"] for t in kept] == ["go to the charging dock", "find the green apple"]
    assert kept[0]["source"] == "browser" and kept[0]["in_grammar"] is True
    recording = client.get(kept[1]["audio_url"])
    assert recording.status_code == 200 and recording.headers["content-type"] == "audio/wav"
    said = synthesize_audio("find the green apple", "en-us", 160).samples
    assert np.array_equal(read_wav_bytes(recording.content).samples, said)  # as sent, to the bit
    assert client.get(kept[1]["audio_url"].replace(f"/{kept[1]['id']}/", "/999/")).status_code == 404


def _latched(client) -> bool:
    return client.get("/api/state").json()["estop_latched"]


def _wait_released(client, timeout_s: float = 30.0) -> bool:
    """The released state reaches the state board with the control loop's next tick."""
    deadline = time.monotonic() + timeout_s
    while _latched(client) and time.monotonic() < deadline:
        time.sleep(0.05)
    return not _latched(client)


def test_a_spoken_stop_from_the_page_latches_the_estop_and_stop_inside_a_command_does_not(client) -> None:
    from robot.speech.tts import synthesize

    assert client.get("/api/config").json()["spoken_stop"] is True
    command = synthesize("go to the dock and stop there", "en-gb", 170)
    heard = client.post("/api/speech/transcribe", content=command, headers={"Content-Type": "audio/wav"}).json()
    assert heard["stop_word"] is False and heard["estop"] is None and not _latched(client), heard
    for phrase, voice in (("stop", "en-us"), ("halt right now", "en-gb"), ("emergency stop", "en-us+f2")):
        wav = synthesize(phrase, voice, 150)
        heard = client.post("/api/speech/transcribe", content=wav, headers={"Content-Type": "audio/wav"}).json()
        assert heard["stop_word"] is True and heard["auto_run"] is False, (phrase, heard)
        assert _latched(client)  # latched before the answer came back, as the button would
        events = [e for e in client.get("/api/events").json() if e["kind"] == "estop/latched"]
        assert events and events[-1]["data"]["source"] == "voice"
        assert client.post("/api/estop/reset").status_code == 200  # release stays the explicit release
        assert _wait_released(client)


def test_the_spoken_stop_can_be_turned_off(client, monkeypatch) -> None:
    from robot.speech.tts import synthesize

    monkeypatch.setattr(client.runtime, "settings", client.runtime.settings.model_copy(update={"spoken_stop": False}))
    assert client.get("/api/config").json()["spoken_stop"] is False
    heard = client.post("/api/speech/transcribe", content=synthesize("stop", "en-us", 150)).json()
    assert heard["text"].startswith("stop") and heard["stop_word"] is False and not _latched(client)


@pytest.fixture
def whisper_client(settings, make_worker):
    from fastapi.testclient import TestClient

    from app.runtime import Runtime
    from app.web.main import create_app

    settings = settings.model_copy(update={"asr_engine": "auto"})
    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    with TestClient(create_app(settings, runtime=runtime)) as test_client:
        test_client.runtime = runtime  # type: ignore[attr-defined]
        yield test_client
    runtime.stop()


def test_the_page_hears_everyday_wording_with_whisper_when_it_is_installed(whisper_client) -> None:
    from robot.speech.tts import synthesize

    wav = synthesize("could you please bring me the red mug", "en-us", 160)
    heard = whisper_client.post("/api/speech/transcribe", content=wav, headers={"Content-Type": "audio/wav"}).json()
    assert heard["engine"] == "whisper" and "bring me the red mug" in heard["text"].lower(), heard
    assert heard["stop_word"] is False and 0.0 < heard["confidence"] <= 1.0
    halt = synthesize("halt please", "en-gb", 160)
    heard = whisper_client.post("/api/speech/transcribe", content=halt, headers={"Content-Type": "audio/wav"}).json()
    assert heard["stop_word"] is True and _latched(whisper_client), heard


def test_the_robots_sentences_are_served_as_speech(client) -> None:
    spoken = client.get("/api/speech/say.wav", params={"text": "I have picked up the red mug."})
    assert spoken.status_code == 200 and spoken.headers["content-type"] == "audio/wav"
    assert spoken.content[:4] == b"RIFF" and len(spoken.content) > 20_000
    assert client.get("/api/speech/say.wav", params={"text": ""}).status_code == 422
