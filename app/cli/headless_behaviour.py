"""`humanoid behaviours`: list the installed behaviours, and run one headless in a fresh simulation, recorded as a
session (its events, feedback and snapshots in the timeline), as fast as the simulation goes."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from app.cli.headless import SETTLE_SIM_S, open_run_session
from app.settings import Settings
from app.web.serialize import behaviour_info_json
from robot.behaviours.registry import discover
from robot.interface import BehaviourState, RobotState, StartBehaviour
from robot.model.world import generate_world
from robot.worker import RobotWorker


def list_behaviours() -> dict[str, Any]:
    """Every behaviour installed (the built-ins and those of other packages), and entry points that failed."""
    registry = discover()
    return {"behaviours": [behaviour_info_json(i) for i in registry.infos()], "broken": registry.broken}


def parse_settings(pairs: list[str]) -> dict[str, str]:
    """`key=value` pairs from the command line (values stay text: the behaviour's parameters type them)."""
    params: dict[str, str] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set takes key=value, got {pair!r}")
        params[key.strip()] = value.strip()
    return params


def run_behaviour(
    name: str,
    params: dict[str, Any],
    seed: int,
    settings: Settings,
    timeout_s: float = 1800.0,
    during: Callable[[RobotWorker, RobotState], None] | None = None,
    worker: RobotWorker | None = None,
) -> dict[str, Any]:
    """Run behaviour `name` to its end (or `timeout_s` of wall time) in a fresh world `seed`; the result the CLI
    prints. `during`: called with each state while it runs (a bench drops obstacles); `worker`: a robot to run it
    on (default: a new one on world `seed`)."""
    worker = worker or RobotWorker(
        generate_world(seed), realtime=False, control_hz=settings.control_hz, planning=settings.planner_config()
    )
    recorder, engine = open_run_session(settings, worker, seed)
    started = time.perf_counter()
    worker.start()
    try:
        worker.wait_for(lambda s: s.sim_time_s >= SETTLE_SIM_S, timeout_s)
        reply = worker.submit(StartBehaviour(name, params, source="cli"))

        def over(state: RobotState) -> bool:
            if during is not None:
                during(worker, state)
            status = state.behaviour
            return status is not None and status.state.finished and status.command_id == reply.command_id

        finished = reply.accepted and worker.wait_for(over, timeout_s)
        state = worker.state()
    finally:
        worker.stop()
    wall = time.perf_counter() - started
    status = state.behaviour if reply.accepted else None
    success = bool(finished and status is not None and status.state == BehaviourState.SUCCEEDED and not state.fallen)
    result: dict[str, Any] = {
        "behaviour": name,
        "params": dict(status.params) if status is not None else params,
        "success": success,
        "state": status.state.value if status is not None else None,
        "reason": status.reason if status is not None else reply.message,
        "machine_state": status.machine_state if status is not None else None,
        "fell": state.fallen,
        "sim_time_s": round(state.sim_time_s, 3),
        "wall_time_s": round(wall, 3),
        "feedback": list(status.feedback) if status is not None else [],
        "session_id": recorder.session_id,
        "seed": seed,
    }
    if not reply.accepted:
        result["error"] = reply.message
        result["errors"] = list(reply.errors)
    elif not finished:
        result["error"] = f"the behaviour did not finish within {timeout_s:.0f} s"
    summary = {k: result[k] for k in ("behaviour", "success", "sim_time_s", "fell")}
    recorder.close(outcome="succeeded" if success else "failed", summary=summary)
    engine.dispose()
    return result
