"""`humanoid run`: the whole loop headless, as fast as the simulation goes, recorded as a session."""

from __future__ import annotations

import time
from typing import Any

from sqlalchemy import Engine

from app.sessions.audio_store import save_recording
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.sessions.maintenance import close_interrupted_sessions
from app.sessions.recorder import SessionRecorder
from app.settings import Settings
from robot.interface import PlanState, RunCommand
from robot.model.world import generate_world
from robot.worker import RobotWorker

SETTLE_SIM_S = 0.5  # let the robot settle on its feet before the command, as an operator would


def open_run_session(settings: Settings, worker: RobotWorker, seed: int) -> tuple[SessionRecorder, Engine]:
    """A headless run's session: the database brought to its newest schema, sessions a crash left open closed, and
    a new session recording `worker`. The caller closes the recorder, then disposes of the engine."""
    upgrade_to_head(settings.database_url)
    engine = make_engine(settings.database_url)
    factory = make_session_factory(engine)
    close_interrupted_sessions(factory)
    recorder = SessionRecorder(
        factory,
        worker,
        kind="run",
        seed=seed,
        audio_dir=settings.audio_dir,
        camera_hz=settings.record_camera_hz,
        camera_width=settings.record_camera_width,
    )
    return recorder, engine


def run_command(
    text: str,
    seed: int,
    settings: Settings,
    timeout_s: float = 300.0,
    heard: tuple[dict[str, Any], bytes] | None = None,
) -> dict[str, Any]:
    """Plan and execute `text` in a fresh simulation; returns the result the CLI prints. `heard`: the transcript
    `text` came from and its recording (WAV), kept with the session."""
    worker = RobotWorker(
        generate_world(seed),
        realtime=False,
        control_hz=settings.control_hz,
        planning=settings.planner_config(),
        max_auto_replans=settings.max_auto_replans,
    )
    recorder, engine = open_run_session(settings, worker, seed)
    started = time.perf_counter()
    worker.start()
    try:
        worker.wait_for(lambda s: s.sim_time_s >= SETTLE_SIM_S, timeout_s)
        if heard is not None:
            transcript, wav = heard
            recorder.record_transcript(transcript, "cli", save_recording(settings.audio_dir, recorder.session_id, wav))
        received = time.time()
        reply = worker.submit(RunCommand(text))
        recorder.record_command(text, "cli-audio" if heard else "cli", reply, received_at=received)
        finished = reply.accepted and worker.wait_for(
            lambda s: (
                s.plan is not None
                and s.plan.command_id == reply.command_id
                and s.plan.state != "running"
                and not s.plan.replanning
            ),
            timeout_s,
        )
        state = worker.state()
    finally:
        worker.stop()
    wall = time.perf_counter() - started
    plan_status = state.plan if reply.accepted else None
    success = bool(finished and plan_status and plan_status.state == PlanState.SUCCEEDED and not state.fallen)
    result: dict[str, Any] = {
        "success": success,
        "transcript": text,
        "plan": reply.plan.to_dict() if reply.plan else None,
        "steps": [
            {"action": s.action, "args": s.args, "status": s.state.value, "detail": s.detail}
            for s in (plan_status.steps if plan_status else ())
        ],
        "sim_time_s": round(state.sim_time_s, 3),
        "wall_time_s": round(wall, 3),
        "fell": state.fallen,
        "held_object": state.held_object,
        "session_id": recorder.session_id,
    }
    if not reply.accepted:
        result["error"] = reply.message
        result["errors"] = list(reply.errors)
    elif not finished:
        result["error"] = f"the plan did not finish within {timeout_s:.0f} s"
    outcome = "succeeded" if success else "failed"
    recorder.close(outcome=outcome, summary={k: result[k] for k in ("success", "transcript", "sim_time_s", "fell")})
    engine.dispose()
    return result
