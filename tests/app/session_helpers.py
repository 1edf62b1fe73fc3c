"""A short recorded session, for the tests of what is stored and how it is reviewed."""

from __future__ import annotations

from app.sessions.audio_store import save_recording
from app.sessions.recorder import SessionRecorder
from robot.interface import EStop, ReleaseEStop, RunCommand


def record_session(factory, worker, audio_dir: str, estop: bool = True) -> int:
    """A short headless session: a spoken and a typed command, an e-stop and its release."""
    recorder = SessionRecorder(factory, worker, kind="run", seed=0, audio_dir=audio_dir, camera_hz=0)
    assert worker.wait_for(lambda s: s.sim_time_s >= 0.5, 30.0)
    wav = b"RIFF" + b"\0" * 40
    heard = {
        "text": "say hello",
        "confidence": 0.8,
        "engine": "pocketsphinx",
        "in_grammar": True,
        "audio_s": 1.2,
        "decode_ms": 40.0,
        "alternatives": ["say hollow"],  # the recogniser's other wording, nearly as likely
    }
    recorder.record_transcript(heard, "cli", save_recording(audio_dir, recorder.session_id, wav))
    reply = worker.submit(RunCommand("say hello"))
    recorder.record_command("say hello", "cli", reply)
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == "succeeded", 30.0)
    recorder.record_command("fly to the moon", "cli", worker.submit(RunCommand("fly to the moon")))
    if estop:
        worker.submit(EStop(source="test"))
        assert worker.wait_for(lambda s: s.estop_latched, 5.0)
        worker.submit(ReleaseEStop(source="test"))
    t = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s >= t + 1.0, 30.0)
    recorder.close(outcome="succeeded")
    return recorder.session_id
