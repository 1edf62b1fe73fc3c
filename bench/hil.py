"""`humanoid bench walk --backend hil`: the walk bench's random velocity scripts played through the
hardware-in-the-loop rig (`robot.hil.rig`): the real-robot backend (`HardwareWorker`: the Dynamixel SDK, the
OpenCR's IMU and the FSR feet read over the emulated bus, the same legs' controller) walks the simulated robot on
an open floor, and the rig's ground truth judges it.

Per script: fell or not, tracking error (final position error over the commanded path, against the commanded
velocities integrated over the rig's physics time; a turn: yaw error over the commanded turn), and the control
loop's figures: tick p50/p99, deadline misses, and the tick split into the bus's round trip (servos' read, sensor
boards' read, goals' write) and the compute. `lockstep`: the rig moves one control period per tick (falls and
tracking as the controller makes them, whatever the machine does); without it, physics runs with the wall clock
and the 100 Hz loop must keep up (the real robot's case). Bars (issue 35): 0 falls over 20 scripts, tracking error
<= 25 %; at 100 Hz with 24 servos, the OpenCR and 2 FSRs on a 2 Mbps bus: no deadline misses over 60 s of
walking, compute p99 <= 3 ms.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

SETTLE_S = 1.0  # standing with torque on before the script, as the simulation's trial does
STOP_S = 2.0
COMMAND_EVERY_S = 0.05  # teleop is a deadman: sent well inside its 300 ms


def hil_trial(seed: int, duration_s: float, lockstep: bool = True) -> dict[str, Any]:
    """One random script (the walk bench's, for this seed) through a fresh rig on an open floor."""
    from robot.control.walk_trial import random_script
    from robot.hardware.worker import HardwareWorker
    from robot.hil.rig import HilRig, rig_config, rig_thresholds
    from robot.interface import SetTorque, Teleop
    from robot.model.world import open_floor

    script = random_script(np.random.default_rng(seed), duration_s)
    layout = open_floor()
    config = rig_config(lockstep=lockstep)
    timeline = [(SETTLE_S, (0.0, 0.0, 0.0))]
    timeline += [(s.duration_s, (s.velocity.vx, s.velocity.vy, s.velocity.yaw_rate)) for s in script]
    timeline.append((STOP_S, (0.0, 0.0, 0.0)))
    with HilRig(layout, config, lockstep=lockstep) as rig:
        robot = HardwareWorker(
            dataclasses.replace(config, port=rig.port_name),
            layout,
            diagnostics=rig_thresholds(lockstep=lockstep),
            deadman_s=0.0,
            walk=True,
        )
        robot.start()
        try:
            robot.submit(SetTorque(True))
            truth = rig.truth()
            while truth.on_stand:  # physics starts with torque
                time.sleep(0.01)
                truth = rig.truth()
            start_t, start_xy, start_yaw = truth.sim_time_s, np.array(truth.base_position[:2]), truth.base_yaw_rad
            ref = [*start_xy, start_yaw]
            distance = commanded_yaw = yaw_total = max_tilt = 0.0
            prev_t, prev_yaw, fell = start_t, start_yaw, False
            for length, velocity in timeline:
                end_t = prev_t + length
                while not fell and truth.sim_time_s < end_t:
                    if velocity != (0.0, 0.0, 0.0):
                        robot.submit(Teleop(*velocity, source="bench"))
                    time.sleep(COMMAND_EVERY_S)
                    truth = rig.truth()
                    dt = min(truth.sim_time_s, end_t) - prev_t
                    c, s = math.cos(ref[2]), math.sin(ref[2])
                    vx, vy, wz = velocity
                    ref = [ref[0] + (c * vx - s * vy) * dt, ref[1] + (s * vx + c * vy) * dt, ref[2] + wz * dt]
                    distance += math.hypot(vx, vy) * dt
                    commanded_yaw += wz * dt
                    yaw_total += math.remainder(truth.base_yaw_rad - prev_yaw, math.tau)
                    prev_t, prev_yaw = min(truth.sim_time_s, end_t), truth.base_yaw_rad
                    max_tilt = max(max_tilt, truth.tilt_deg)
                    fell = truth.fallen
                if fell:
                    break
            time.sleep(1.1)  # the loop's statistics refresh once a second
            control = robot.state().control
            legs = robot.state().locomotion
            split = robot.body.tick_split.summary()
        finally:
            robot.stop()
    error = math.hypot(truth.base_position[0] - ref[0], truth.base_position[1] - ref[1])
    yaw_error = start_yaw + yaw_total - ref[2]
    if fell:
        tracking = None
    elif distance >= 0.1:
        tracking = error / distance
    elif abs(commanded_yaw) >= 0.3:
        tracking = abs(yaw_error) / abs(commanded_yaw)
    else:
        tracking = 0.0
    return {
        "seed": seed,
        "fell": fell,
        "physics_s": truth.sim_time_s - start_t,
        "commanded_distance_m": distance,
        "position_error_m": error,
        "yaw_error_rad": yaw_error,
        "tracking_error": tracking,
        "max_tilt_deg": max_tilt,
        "tick_p50_ms": control.tick_p50_ms,
        "tick_p99_ms": control.tick_p99_ms,
        "deadline_misses": control.deadline_misses,
        "ticks": control.ticks,
        "late_physics_blocks": truth.late_blocks,
        "late_walk_plans": legs.late_plans if legs is not None else 0,
        "late_walk_plans_s": round(legs.late_plans_s, 3) if legs is not None else 0.0,
        **{k: round(v, 3) for k, v in split.items()},
    }


def run_hil_walk(scripts: int = 20, duration_s: float = 60.0, seed: int = 0, lockstep: bool = True) -> dict[str, Any]:
    """The scripts one after another (each rig and robot take the machine's cores as the real ones would)."""
    started = time.perf_counter()
    trials = [hil_trial(s, duration_s, lockstep) for s in range(seed, seed + scripts)]
    errors = [t["tracking_error"] for t in trials if t["tracking_error"] is not None]
    return {
        "suite": "walk",
        "backend": "hil",
        "lockstep": lockstep,
        "scripts": scripts,
        "script_duration_s": duration_s,
        "falls": sum(t["fell"] for t in trials),
        "tracking_error_mean": float(np.mean(errors)) if errors else None,
        "tracking_error_max": float(np.max(errors)) if errors else None,
        "deadline_misses": sum(t["deadline_misses"] for t in trials),
        "tick_p99_ms_max": max(t["tick_p99_ms"] for t in trials),
        "bus_p99_ms_max": max(t["bus_p99_ms"] for t in trials),
        "compute_p99_ms_max": max(t["compute_p99_ms"] for t in trials),
        "wall_time_s": time.perf_counter() - started,
        "trials": trials,
    }
