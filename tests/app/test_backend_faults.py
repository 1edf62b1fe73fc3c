"""The server's backends fail: the speech recogniser hangs or dies, the LLM server hangs or goes away. Each is
detected within its timeout, said to the operator, logged, and the server and the robot go on; the operator's
recording is kept whatever happened to its transcription."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select

from app.runtime import Runtime
from app.sessions.models import TranscriptRow
from app.web.api import speech
from app.web.main import create_app
from robot.speech.tts import synthesize
from tests.app.test_api import wait_until

WAV = {"Content-Type": "audio/wav"}


@pytest.fixture
def asr_client(settings, make_worker) -> Iterator[TestClient]:
    settings = settings.model_copy(update={"asr_timeout_s": 2.0})
    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    with TestClient(create_app(settings, runtime=runtime)) as client:
        client.runtime = runtime  # type: ignore[attr-defined]
        yield client
    runtime.stop()


def recognizer_pid(client) -> int:
    return speech.recognizer(client.runtime).pid


def transcripts(client) -> list[TranscriptRow]:
    rt = client.runtime
    with rt.db() as db:
        return list(db.scalars(select(TranscriptRow).where(TranscriptRow.session_id == rt.recorder.session_id)))


def test_a_hung_recogniser_is_stopped_at_its_timeout_and_the_next_recording_gets_a_new_one(asr_client) -> None:
    wav = synthesize("go to the charging dock", "en-us", 160)
    hung = recognizer_pid(asr_client)
    os.kill(hung, signal.SIGSTOP)  # a decoder stuck for good
    try:
        failed = asr_client.post("/api/speech/transcribe", content=wav, headers=WAV)
        assert failed.status_code == 503
        assert "no answer within 2 s" in failed.json()["detail"]["message"]
        kept = transcripts(asr_client)[-1]  # the recording is kept with an empty transcript
        audio_dir = Path(asr_client.runtime.settings.audio_dir)
        assert kept.text == "" and kept.audio_path and (audio_dir / kept.audio_path).stat().st_size > 40_000
        assert asr_client.get("/api/health").status_code == 200
    finally:
        with contextlib.suppress(ProcessLookupError):  # (the server has killed it: nothing to resume)
            os.kill(hung, signal.SIGCONT)
    heard = asr_client.post("/api/speech/transcribe", content=wav, headers=WAV)
    assert heard.status_code == 200 and heard.json()["text"] == "go to the charging dock"
    assert recognizer_pid(asr_client) != hung


def test_a_recogniser_that_died_is_started_again_and_hears_the_recording(asr_client) -> None:
    wav = synthesize("find the green apple", "en-us", 160)
    dead = recognizer_pid(asr_client)
    os.kill(dead, signal.SIGKILL)  # gone before the recording comes, or (a busy machine) while it is being decoded
    heard = asr_client.post("/api/speech/transcribe", content=wav, headers=WAV)
    assert heard.status_code == 200 and heard.json()["text"] == "find the green apple"
    assert recognizer_pid(asr_client) != dead


class SilentServer:
    """An LLM server that accepts connections and never answers (hung), until it is closed (gone)."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}/v1"
        self.held: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.held.append(conn)

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)  # (wakes the thread blocked in accept, which holds it open)
        self.sock.close()
        for conn in self.held:
            conn.close()


@pytest.fixture
def llm_client(settings, make_worker) -> Iterator[tuple[TestClient, SilentServer]]:
    server = SilentServer()
    settings = settings.model_copy(
        update={"planner_backend": "openai", "openai_base_url": server.url, "openai_timeout_s": 1.0}
    )
    runtime = Runtime.start(settings, worker=make_worker(realtime=True, planning=settings.planner_config()))
    with TestClient(create_app(settings, runtime=runtime)) as client:
        client.runtime = runtime  # type: ignore[attr-defined]
        yield client, server
    runtime.stop()
    server.close()


def test_a_hung_then_dead_llm_server_falls_back_to_rules_and_says_why(llm_client) -> None:
    client, server = llm_client
    hung = client.post("/api/commands", json={"text": "say the model is asleep"})
    assert hung.status_code == 202 and hung.json()["plan"]["steps"][0]["action"] == "say"
    fallback = wait_until(lambda: [e for e in client.get("/api/events").json() if e["kind"] == "plan/fallback"])
    assert "timed out after 1 s" in fallback[-1]["message"] and fallback[-1]["level"] == 1  # WARN
    server.close()  # now it is gone altogether
    gone = client.post("/api/commands", json={"text": "say the model is gone"})
    assert gone.status_code == 202
    fallback = wait_until(
        lambda: len(e := [e for e in client.get("/api/events").json() if e["kind"] == "plan/fallback"]) == 2 and e
    )
    assert "cannot reach" in fallback[-1]["message"]
    assert client.get("/api/health").status_code == 200 and not client.runtime.worker.state().estop_latched
