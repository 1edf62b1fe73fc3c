"""`humanoid run` end to end in a subprocess, as a user runs it."""

from __future__ import annotations

import json
import sqlite3

import pytest

from tests.support.cli import humanoid as run_humanoid
from tests.support.cli import humanoid_here

RESULT_KEYS = {
    "success",
    "transcript",
    "plan",
    "steps",
    "sim_time_s",
    "wall_time_s",
    "fell",
    "held_object",
    "session_id",
}


def humanoid(tmp_path, *args: str, timeout_s: float = 120.0, env: dict[str, str] | None = None):
    """The command with its database and recordings in this test's folder."""
    own = {"DATABASE_URL": f"sqlite:///{tmp_path / 'cli.db'}", "HUMANOID_AUDIO_DIR": str(tmp_path / "audio")}
    return run_humanoid(*args, env={**own, **(env or {})}, timeout_s=timeout_s)


def here(tmp_path, *args: str):
    """The same, in this process (a command that starts no robot): its output and exit code as a process's."""
    own = {"DATABASE_URL": f"sqlite:///{tmp_path / 'cli.db'}", "HUMANOID_AUDIO_DIR": str(tmp_path / "audio")}
    return humanoid_here(*args, env=own)


def test_run_prints_the_result_and_records_a_session(tmp_path) -> None:
    done = humanoid(tmp_path, "run", "say hello from the cli", "--seed", "3", "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result.keys() >= RESULT_KEYS
    assert result["success"] is True and result["fell"] is False
    assert result["steps"] == [
        {
            "action": "say",
            "args": {"text": "hello from the cli"},
            "status": "succeeded",
            "detail": 'said "hello from the cli"',
        }
    ]
    assert result["session_id"] == 1
    assert result["sim_time_s"] > 0

    second = json.loads(humanoid(tmp_path, "run", "wait for one second", "--json").stdout)
    assert second["session_id"] == 2 and second["success"] is True  # a session each (the whole fetch: below)
    assert second["wall_time_s"] > 0  # how fast it ran is `humanoid bench capstone`'s to measure, not a test's


@pytest.mark.slow
def test_bring_carries_the_mug_to_the_table_and_puts_it_down(tmp_path) -> None:
    """The whole fetch: walk, find, grasp, back away from the counter carrying it, walk, put it down at a free spot
    in reach of where the robot stopped, check it stands there, say so."""
    # (as fast as the simulation goes: ~90 s on an idle machine, over 300 s with one core kept busy, so a limit of
    # its own; how fast it runs is `humanoid bench capstone`'s to measure)
    done = humanoid(
        tmp_path,
        "run",
        "bring the red mug to the living-room table",
        "--seed",
        "2",
        "--json",
        "--timeout",
        "1500",
        timeout_s=1600,
    )
    result = json.loads(done.stdout)
    steps = result["steps"]
    assert [s["action"] for s in steps] == [
        "navigate_to",
        "detect_object",
        "pick_object",
        "navigate_to",
        "place_object",
        "say",
    ]
    assert [s["status"] for s in steps] == ["succeeded"] * 6, steps
    assert result["success"] is True and result["held_object"] is None and not result["fell"]
    assert "at the kitchen counter" in steps[0]["detail"]
    assert "found red mug at" in steps[1]["detail"]
    assert "holding the red mug" in steps[2]["detail"]
    assert "put the red mug on the living-room table" in steps[4]["detail"]


def test_run_with_an_unknown_object_fails_clearly(tmp_path) -> None:
    done = humanoid(tmp_path, "run", "pick up the purple elephant", "--json")
    assert done.returncode == 1
    result = json.loads(done.stdout)
    assert result["success"] is False and "purple elephant" in result["error"]


def test_bad_arguments_are_refused(tmp_path) -> None:
    done = here(tmp_path, "run", "say hi", "--seed", "-2")
    assert done.returncode == 2 and "--seed must be >= 0" in done.stderr


def test_bench_walk_writes_its_figures_as_json(tmp_path) -> None:
    out = tmp_path / "walk.json"
    # 6 s of real time: a third of it walking forward (3 s left ~2 cm after the start-up, and under load less)
    done = humanoid(
        tmp_path,
        "bench",
        "walk",
        "--scripts",
        "2",
        "--script-duration",
        "8",
        "--realtime-duration",
        "6",
        "--output",
        str(out),
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(out.read_text())
    assert result["scripts"] == 2 and len(result["trials"]) == 2
    keys = ("falls", "tracking_error_mean", "lateral_drift_m_per_m_mean", "lateral_drift_from_standing_m_per_m_mean")
    for key in (*keys, "max_tilt_deg"):
        assert key in result
    assert all(len(t["script"]) >= 1 for t in result["trials"])
    realtime = result["realtime"]
    # (its speed is a figure, not a test: no bound on the real-time factor)
    assert realtime["tick_p99_ms"] > 0 and realtime["rtf"] > 0 and realtime["walked_m"] > 0.01  # it walked


def test_bench_capstone_names_the_tasks_it_knows_when_given_another(tmp_path) -> None:
    done = here(tmp_path, "bench", "capstone", "--tasks", "pick,juggle", "--seeds", "1")
    assert done.returncode == 2
    assert "juggle" in done.stderr and "pick, bring, blocked" in done.stderr


def test_plan_prints_the_validated_plan_in_the_seeds_format_without_moving_anything(tmp_path) -> None:
    done = here(tmp_path, "plan", "bring the red mug to the living-room table", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == [
        {"action": "navigate_to", "target": "kitchen counter"},
        {"action": "detect_object", "object": "red mug"},
        {"action": "pick_object", "object": "red mug"},
        {"action": "navigate_to", "target": "living-room table"},
        {"action": "place_object", "location": "living-room table"},
        {"action": "say", "text": "I have put the red mug on the living-room table."},
    ]
    holding = here(tmp_path, "plan", "put it on the counter", "--holding", "mug", "--json")
    assert [s["action"] for s in json.loads(holding.stdout)] == ["navigate_to", "place_object", "say"]
    unknown = here(tmp_path, "plan", "pick up the purple elephant", "--json")
    assert unknown.returncode == 1 and "unknown object 'purple elephant'" in unknown.stderr and unknown.stdout == ""
    asked = here(tmp_path, "plan", "go to the kitchen table", "--json")
    assert asked.returncode == 1 and json.loads(asked.stdout) == {
        "clarify": "Did you mean the living-room table or the kitchen counter?",
        "options": ["living-room table", "kitchen counter"],
        "plan": None,
    }


def test_bench_language_reports_both_sets_against_the_bars(tmp_path) -> None:
    out = tmp_path / "language.json"
    done = humanoid(tmp_path, "bench", "language", "--output", str(out))
    assert done.returncode == 0, done.stderr
    result = json.loads(out.read_text())
    assert set(result["typed"]) == {"dev", "heldout"} and result["spoken"]["measured"] is False
    for figures in (result["typed"]["dev"]["rules"], result["typed"]["heldout"]["rules"]):
        assert figures["everyday_right"]["of"] >= 60 and figures["out_of_world_right"]["of"] >= 20
        assert set(figures["latency_ms"]) == {"p50", "p99", "max"}
    assert len(result["bars"]) == 6 and all(bar["met"] for bar in result["bars"].values()), result["bars"]


def test_plan_with_an_unreachable_llm_falls_back_to_rules_and_says_why(tmp_path) -> None:
    env_url = {"HUMANOID_OPENAI_BASE_URL": "http://127.0.0.1:9/v1"}
    done = run_humanoid("plan", "go to the dock", "--backend", "openai", "--json", env=env_url, timeout_s=60)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)[0] == {"action": "navigate_to", "target": "charging dock"}
    assert "openai: cannot reach http://127.0.0.1:9/v1" in done.stderr and "planned by rules instead" in done.stderr


def test_bench_planner_measures_the_rules_on_the_paraphrase_suite(tmp_path) -> None:
    out = tmp_path / "planner.json"
    done = humanoid(tmp_path, "bench", "planner", "--output", str(out))
    assert done.returncode == 0, done.stderr
    result = json.loads(out.read_text())
    rules = result["backends"]["rules"]
    assert result["cases"] >= 60 and rules["runs"] == result["cases"]
    assert rules["exact_rate"] == 1.0 and rules["wrong"] == [], rules["wrong"]
    assert result["bars"]["rules_exact"]["measured"] == rules["exact_rate"]
    assert set(rules["latency_ms"]) == {"p50", "p99", "max", "mean"}


def test_transcribe_prints_text_and_confidence_and_run_takes_a_spoken_command(tmp_path) -> None:
    from robot.speech.tts import synthesize

    wav = tmp_path / "command.wav"
    wav.write_bytes(synthesize("wait for three seconds", "en-us", 160))
    done = humanoid(tmp_path, "transcribe", str(wav), "--json", "--engine", "pocketsphinx")
    assert done.returncode == 0, done.stderr
    heard = json.loads(done.stdout)
    assert heard["text"] == "wait for three seconds" and 0.0 < heard["confidence"] <= 1.0
    assert heard["engine"] == "pocketsphinx" and heard["in_grammar"] is True and heard["stop_word"] is False

    run = humanoid(tmp_path, "run", "--audio", str(wav), "--json", env={"HUMANOID_ASR_ENGINE": "pocketsphinx"})
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["success"] and result["transcript"] == "wait for three seconds"
    assert result["speech"]["file"] == str(wav) and result["steps"][0]["detail"] == "waited 3 s"
    with sqlite3.connect(tmp_path / "cli.db") as db:  # kept with the run's session, with its recording
        rows = db.execute("SELECT session_id, source, text, audio_path FROM transcripts").fetchall()
    assert [(r[0], r[1], r[2]) for r in rows] == [(result["session_id"], "cli", "wait for three seconds")]
    assert (tmp_path / "audio" / rows[0][3]).stat().st_size > 10_000

    missing = humanoid(tmp_path, "transcribe", str(tmp_path / "nope.wav"))
    assert missing.returncode == 2 and "no such audio file" in missing.stderr


def test_transcribe_hears_everyday_wording_with_whisper_by_default_and_reports_a_spoken_stop(tmp_path) -> None:
    from robot.speech.tts import synthesize

    command, stop = tmp_path / "command.wav", tmp_path / "stop.wav"
    command.write_bytes(synthesize("walk to the kitchen counter and stop there", "en-gb", 170))
    stop.write_bytes(synthesize("stop right now", "en-us", 150))
    heard = json.loads(humanoid(tmp_path, "transcribe", str(command), "--json").stdout)
    assert heard["engine"] == "whisper"  # the test set-up installs the whisper extra: it is the default
    assert "stop there" in heard["text"].lower() and heard["stop_word"] is False, heard
    assert all(isinstance(w, str) for w in heard["further_wordings"])  # the rest of the beam, for the stop
    halted = json.loads(humanoid(tmp_path, "transcribe", str(stop), "--json").stdout)
    assert halted["stop_word"] is True, halted
    grammar = json.loads(humanoid(tmp_path, "transcribe", str(stop), "--json", "--engine", "pocketsphinx").stdout)
    assert grammar["stop_word"] is True and grammar["engine"] == "pocketsphinx", grammar


def test_sessions_are_listed_shown_exported_imported_and_deleted_from_the_command_line(tmp_path) -> None:
    assert humanoid(tmp_path, "run", "say hello from the cli", "--json").returncode == 0  # (the rest: in this process)
    listed = json.loads(here(tmp_path, "sessions", "list", "--json").stdout)
    assert listed["total"] == 1 and listed["items"][0]["first_command"] == "say hello from the cli"
    assert json.loads(here(tmp_path, "sessions", "list", "--json", "--had-estop", "yes").stdout)["total"] == 0
    shown = here(tmp_path, "sessions", "show", "1")
    assert shown.returncode == 0 and '"say hello from the cli" from cli: accepted' in shown.stdout
    for fmt in ("json", "mcap"):
        out = tmp_path / f"s1.{fmt}"
        done = here(tmp_path, "sessions", "export", "1", "--format", fmt, "-o", str(out))
        assert done.returncode == 0, done.stderr
        assert out.stat().st_size > 10_000
    assert (tmp_path / "s1.mcap").read_bytes()[:8] == b"\x89MCAP0\r\n"
    imported = here(tmp_path, "sessions", "import", str(tmp_path / "s1.json"), "--json")
    assert json.loads(imported.stdout) == {"session_id": 2}
    assert here(tmp_path, "sessions", "delete", "2").returncode == 1  # asks for --yes first
    assert here(tmp_path, "sessions", "delete", "2", "--yes").returncode == 0
    assert here(tmp_path, "sessions", "export", "9", "-o", str(tmp_path / "x.json")).returncode == 1
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "zip"}')
    refused = here(tmp_path, "sessions", "import", str(bad))
    assert refused.returncode == 1 and "not a session export" in refused.stderr
    assert json.loads(here(tmp_path, "sessions", "list", "--json").stdout)["total"] == 1


def test_describe_writes_the_robots_urdf_alone(tmp_path) -> None:
    import yourdfpy

    done = here(tmp_path, "describe", "--urdf", "-o", str(tmp_path / "robot.urdf"))
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""  # the file alone: nothing else on standard output
    robot = yourdfpy.URDF.load(str(tmp_path / "robot.urdf"), load_meshes=False, load_collision_meshes=False)
    assert robot.robot.name == "humanoid_v1" and len(robot.actuated_joint_names) == 24
    summary = here(tmp_path, "describe")
    assert summary.returncode == 0 and "r_knee" in summary.stdout
