"""What a headless robot costs per control tick (10 ms of simulated time): standing, then walking to the dock on its
own map. Headless tests and benches run as fast as this allows, so it sets their wall time.

    .venv/bin/python scripts/tick_cost.py [--seed 0] [--stand-seconds 30]

Prints JSON: wall and CPU microseconds per tick of the robot's process, how much of that is MuJoCo's physics, and
the CPU its child processes (the sensors': camera, detector, lidar, map) used per tick.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable

import psutil

from robot.interface import ExecutePlan, PlanState
from robot.model.world import generate_world
from robot.sim.backend import MujocoSimBackend
from robot.worker import RobotWorker

TICKS_PER_SIM_S = 100


class TimedBackend(MujocoSimBackend):
    """The simulation, with the time its physics steps take added up."""

    physics_s = 0.0

    def step(self, duration_s: float) -> None:
        started = time.perf_counter()
        try:
            super().step(duration_s)
        finally:
            self.physics_s += time.perf_counter() - started


def _children_cpu_s() -> float:
    """CPU used so far by the processes this one started and that still run (the sensors', the gait planner's)."""
    total = 0.0
    for child in psutil.Process().children(recursive=True):
        try:
            times = child.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += times.user + times.system
    return total


def _measure(worker: RobotWorker, backend: TimedBackend, run: Callable[[], object]) -> dict[str, float]:
    sim0, wall0, cpu0 = worker.state().sim_time_s, time.perf_counter(), time.process_time()
    physics0, children0 = backend.physics_s, _children_cpu_s()
    run()
    ticks = (worker.state().sim_time_s - sim0) * TICKS_PER_SIM_S
    return {
        "ticks": round(ticks),
        "wall_us_per_tick": round((time.perf_counter() - wall0) / ticks * 1e6),
        "cpu_us_per_tick": round((time.process_time() - cpu0) / ticks * 1e6),
        "physics_us_per_tick": round((backend.physics_s - physics0) / ticks * 1e6),
        "child_processes_cpu_us_per_tick": round((_children_cpu_s() - children0) / ticks * 1e6),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--stand-seconds", type=float, default=30.0, help="simulated seconds standing")
    args = parser.parse_args()
    layout = generate_world(args.seed)
    backend = TimedBackend(layout)
    worker = RobotWorker(layout, backend=backend, realtime=False)
    worker.start()
    try:
        assert worker.wait_for(lambda s: s.sim_time_s > 1.0, 120), "the robot did not start"
        start = worker.state().sim_time_s
        standing = _measure(
            worker, backend, lambda: worker.wait_for(lambda s: s.sim_time_s > start + args.stand_seconds, 600)
        )

        def walk() -> None:
            steps = [{"action": "navigate_to", "args": {"target": "charging dock"}}]
            assert worker.submit(ExecutePlan({"steps": steps})).accepted
            assert worker.wait_for(lambda s: s.plan is not None and s.plan.state != PlanState.RUNNING, 900)

        walking = _measure(worker, backend, walk)
        walking["arrived"] = worker.state().plan.state == PlanState.SUCCEEDED
    finally:
        worker.stop()
    print(json.dumps({"seed": args.seed, "standing": standing, "walking": walking}, indent=2))


if __name__ == "__main__":
    main()
