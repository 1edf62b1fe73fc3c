"""`humanoid run`: the whole loop headless, as fast as the simulation goes, recorded as a session."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from sqlalchemy import Engine

from app.sessions.audio_store import save_recording
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.sessions.maintenance import close_interrupted_sessions
from app.sessions.recorder import SessionRecorder
from app.settings import Settings
from robot.interface import PlanState, RobotPort, RunCommand, SetTorque
from robot.model.world import generate_world
from robot.worker import RobotWorker

if TYPE_CHECKING:
    from robot.hil.rig import HilRig

SETTLE_SIM_S = 0.5  # let the robot settle on its feet before the command, as an operator would


def open_run_session(settings: Settings, worker: RobotPort, seed: int) -> tuple[SessionRecorder, Engine]:
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
    backend: str = "sim",
) -> dict[str, Any]:
    """Plan and execute `text` in a fresh simulation; returns the result the CLI prints. `heard`: the transcript
    `text` came from and its recording (WAV), kept with the session. `backend` "hil": the real-robot backend
    drives the simulated robot through the hardware-in-the-loop rig (in lockstep), judged by the rig's physics."""
    if backend == "hil":
        from robot.hardware.worker import HardwareWorker
        from robot.hil.rig import HilRig, rig_config, rig_thresholds

        layout = generate_world(seed)
        with HilRig(layout, rig_config(lockstep=True), lockstep=True) as rig:
            robot = HardwareWorker(
                rig.robot_config(),
                layout,
                diagnostics=rig_thresholds(settings.diagnostics, lockstep=True),
                disk_path=settings.data_dir,
                deadman_s=0.0,
                walk=True,
                wait_for_plans=True,
            )
            return _run_on(robot, text, seed, settings, timeout_s, heard, rig)
    worker = RobotWorker(
        generate_world(seed),
        realtime=False,
        diagnostics=settings.diagnostics,
        control_hz=settings.control_hz,
        planning=settings.planner_config(),
        max_auto_replans=settings.max_auto_replans,
    )
    return _run_on(worker, text, seed, settings, timeout_s, heard)


def _run_on(
    worker: RobotPort,
    text: str,
    seed: int,
    settings: Settings,
    timeout_s: float,
    heard: tuple[dict[str, Any], bytes] | None,
    rig: HilRig | None = None,
) -> dict[str, Any]:
    """`rig`: the robot is on the rig: torque on first, and the rig's physics says how long it took and whether it
    fell."""
    recorder, engine = open_run_session(settings, worker, seed)
    started = time.perf_counter()
    worker.start()
    try:
        if rig is not None:
            worker.submit(SetTorque(True))
            deadline = time.monotonic() + timeout_s
            while rig.truth().sim_time_s < SETTLE_SIM_S and time.monotonic() < deadline:
                time.sleep(0.05)
        else:
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
        truth = rig.truth() if rig is not None else None
    finally:
        worker.stop()
    wall = time.perf_counter() - started
    plan_status = state.plan if reply.accepted else None
    fell = state.fallen or (truth is not None and truth.fallen)
    success = bool(finished and plan_status and plan_status.state == PlanState.SUCCEEDED and not fell)
    result: dict[str, Any] = {
        "success": success,
        "transcript": text,
        "plan": reply.plan.to_dict() if reply.plan else None,
        "steps": [
            {"action": s.action, "args": s.args, "status": s.state.value, "detail": s.detail}
            for s in (plan_status.steps if plan_status else ())
        ],
        "sim_time_s": round(truth.sim_time_s if truth is not None else state.sim_time_s, 3),
        "wall_time_s": round(wall, 3),
        "fell": fell,
        "held_object": state.held_object,
        "session_id": recorder.session_id,
    }
    if truth is not None:  # what the robot cannot know: where it really ended, and the objects
        result["rig"] = {
            "base_position": [round(v, 3) for v in truth.base_position],
            "base_yaw_rad": round(truth.base_yaw_rad, 3),
            "objects": {name: [round(v, 3) for v in xyz] for name, xyz in truth.objects.items()},
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
