"""Walk trials: drive the simulated robot through a velocity script and measure how well it followed it.

Used by `humanoid bench walk` and by the physics tests. The tracking error is the final displacement against the
integrated command (the command's path, in the start frame), the lateral drift is sideways metres per metre
travelled on straight forward/backward segments, and a fall is the backend's fall test.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robot.control.locomotion import LocomotionController, Velocity, VelocityLimits
from robot.control.odometry import Pose2D
from robot.control.stack import CONTROL_DT, build_locomotion, sensors
from robot.control.stack import measured_pose as true_pose
from robot.sim.backend import MujocoSimBackend

DT = CONTROL_DT
# Lateral drift is measured on straight segments from this long after their start, over at least 0.2 m, against
# the heading averaged from HEADING_WINDOW_S to DRIFT_SETTLE_S.
DRIFT_SETTLE_S = 1.0
HEADING_WINDOW_S = 0.4


@dataclass(frozen=True)
class ScriptSegment:
    duration_s: float
    velocity: Velocity


def random_script(
    rng: np.random.Generator, duration_s: float, limits: VelocityLimits | None = None
) -> list[ScriptSegment]:
    """Segments of 3-8 s: straight walks forward/backward/sideways, turns, mixes and stops, within the limits."""
    limits = limits or VelocityLimits()
    segments: list[ScriptSegment] = []
    total = 0.0
    while total < duration_s:
        length = min(float(rng.uniform(3.0, 8.0)), duration_s - total)
        kind = rng.choice(["forward", "backward", "left", "right", "turn", "mixed", "stop"])
        vx = vy = wz = 0.0
        if kind == "forward":
            vx = float(rng.uniform(0.05, limits.vx_forward))
        elif kind == "backward":
            vx = -float(rng.uniform(0.04, limits.vx_backward))
        elif kind in ("left", "right"):
            vy = float(rng.uniform(0.02, limits.vy)) * (1 if kind == "left" else -1)
        elif kind == "turn":
            wz = float(rng.uniform(0.2, 0.6)) * float(rng.choice([-1, 1]))
        elif kind == "mixed":
            vx = float(rng.uniform(0.0, 0.12))
            wz = float(rng.uniform(-0.3, 0.3))
        segments.append(ScriptSegment(length, Velocity(vx, vy, wz)))
        total += length
    return segments


@dataclass
class TrialResult:
    fell: bool
    fall_time_s: float | None
    commanded_distance_m: float
    position_error_m: float
    yaw_error_rad: float
    commanded_yaw_rad: float
    lateral_drift_m_per_m: list[float] = field(default_factory=list)
    tick_ms: list[float] = field(default_factory=list)
    max_tilt_deg: float = 0.0
    lateral_drift_vs_command_m_per_m: list[float] = field(default_factory=list)
    lateral_drift_from_standing_m_per_m: list[float] = field(default_factory=list)

    @property
    def tracking_error(self) -> float:
        """Final position error relative to the commanded path length (turns: yaw error relative to the turn)."""
        if self.commanded_distance_m >= 0.1:
            return self.position_error_m / self.commanded_distance_m
        if abs(self.commanded_yaw_rad) >= 0.3:
            return abs(self.yaw_error_rad) / abs(self.commanded_yaw_rad)
        return 0.0


def run_trial(
    script: list[ScriptSegment],
    backend: MujocoSimBackend,
    loco: LocomotionController,
    settle_s: float = 1.0,
    stop_s: float = 2.0,
) -> TrialResult:
    """Stand for `settle_s`, play the script, then stop and stand for `stop_s`; measures against ground truth."""
    backend.reset(loco.stand_targets)
    m = backend.read()
    loco.reset_odometry(true_pose(m), sensors(m))
    hold = loco.stand_targets
    ref = true_pose(m)
    start = ref
    timeline: list[tuple[float, Velocity]] = [(settle_s, Velocity())]
    timeline += [(seg.duration_s, seg.velocity) for seg in script]
    timeline.append((stop_s, Velocity()))
    ticks: list[float] = []
    max_tilt = 0.0
    yaw_total = 0.0
    commanded_yaw = 0.0
    prev_yaw = m.yaw_rad
    distance = 0.0
    drifts: list[float] = []
    drifts_vs_command: list[float] = []  # the same, against the commanded line (heading lag from turns counts)
    # straight walks started from standing, against the heading it stood with (no sway, no lag inherited)
    drifts_from_standing: list[float] = []
    off_command_start = 0.0
    t = 0.0
    previous = Velocity()
    for duration, velocity in timeline:
        from_standing = previous == Velocity()
        previous = velocity
        loco.set_velocity(velocity)
        line: Pose2D | None = None  # the straight line the robot is pointed along, once settled into the segment
        heading = np.zeros(2)
        distance_start = 0.0
        standing_line, standing_distance = true_pose(backend.read()), distance  # exact heading: no step sway
        for i in range(round(duration / DT)):
            if i >= int(HEADING_WINDOW_S / DT) and line is None:  # heading sways +-3 deg a step: average it
                yaw = true_pose(backend.read()).yaw
                heading += (math.cos(yaw), math.sin(yaw))
            if i == int(DRIFT_SETTLE_S / DT):  # the lag behind the previous segment's motion has resolved by now
                here = true_pose(backend.read())
                line, distance_start = Pose2D(here.x, here.y, math.atan2(heading[1], heading[0])), distance
                off_command_start = _lateral_offset(here, ref)
            m = backend.read()
            planner = loco.walking.planner
            planner.last_wait_ms = 0.0
            started = time.perf_counter()
            targets = loco.update(sensors(m), hold)
            # faster than real time the tick may wait for a plan that in real time is ready 50 ms early
            ticks.append((time.perf_counter() - started) * 1e3 - getattr(planner, "last_wait_ms", 0.0))
            backend.write(targets)
            backend.step(DT)
            t += DT
            # the reference integrates the shaped command the controller actually received
            v = loco.velocity.current
            c, s = math.cos(ref.yaw), math.sin(ref.yaw)
            ref = Pose2D(
                ref.x + (c * v.vx - s * v.vy) * DT, ref.y + (s * v.vx + c * v.vy) * DT, ref.yaw + v.yaw_rate * DT
            )
            distance += math.hypot(v.vx, v.vy) * DT
            commanded_yaw += v.yaw_rate * DT
            m = backend.read()
            yaw_total += math.remainder(m.yaw_rad - prev_yaw, math.tau)
            prev_yaw = m.yaw_rad
            max_tilt = max(max_tilt, m.tilt_deg)
            if m.fallen:
                loco.halt()
                nan = float("nan")
                return TrialResult(
                    True,
                    t,
                    distance,
                    nan,
                    nan,
                    commanded_yaw,
                    drifts,
                    ticks,
                    max_tilt,
                    drifts_vs_command,
                    drifts_from_standing,
                )
        travelled = distance - distance_start
        if line is not None and velocity.vy == 0.0 and velocity.yaw_rate == 0.0 and travelled > 0.2:
            # sideways departure from the line the robot was pointed along, per metre commanded
            end_pose = true_pose(backend.read())
            drifts.append(abs(_lateral_offset(end_pose, line)) / travelled)
            drifts_vs_command.append(abs(_lateral_offset(end_pose, ref) - off_command_start) / travelled)
            if from_standing:
                along = distance - standing_distance
                drifts_from_standing.append(abs(_lateral_offset(end_pose, standing_line)) / along)
    end = true_pose(backend.read())
    error = math.hypot(end.x - ref.x, end.y - ref.y)
    yaw_error = (start.yaw + yaw_total) - ref.yaw
    return TrialResult(
        False,
        None,
        distance,
        error,
        yaw_error,
        commanded_yaw,
        drifts,
        ticks,
        max_tilt,
        drifts_vs_command,
        drifts_from_standing,
    )


def _lateral_offset(actual: Pose2D, reference: Pose2D) -> float:
    """How far `actual` is to the left of `reference`, across the reference heading (m)."""
    return -math.sin(reference.yaw) * (actual.x - reference.x) + math.cos(reference.yaw) * (actual.y - reference.y)


def trial_in_new_sim(seed: int, duration_s: float, pose_loop: bool = True, planner_process: bool = True) -> dict:
    """One random script on a fresh simulator with an open floor (a self-contained job for a worker process)."""
    from robot.model.world import open_floor

    rng = np.random.default_rng(seed)
    script = random_script(rng, duration_s)
    backend = MujocoSimBackend(open_floor())
    with tempfile.TemporaryDirectory() as tmp:
        loco = build_locomotion(backend, Path(tmp), planner_process=planner_process, pose_loop=pose_loop)
        result = run_trial(script, backend, loco)
        loco.walking.planner.close()
    return {
        "seed": seed,
        "fell": result.fell,
        "fall_time_s": result.fall_time_s,
        "commanded_distance_m": result.commanded_distance_m,
        "position_error_m": result.position_error_m,
        "commanded_yaw_rad": result.commanded_yaw_rad,
        "yaw_error_rad": result.yaw_error_rad,
        "tracking_error": result.tracking_error if not result.fell else None,
        "lateral_drift_m_per_m": result.lateral_drift_m_per_m,
        "lateral_drift_vs_command_m_per_m": result.lateral_drift_vs_command_m_per_m,
        "lateral_drift_from_standing_m_per_m": result.lateral_drift_from_standing_m_per_m,
        "max_tilt_deg": result.max_tilt_deg,
        "tick_p50_ms": float(np.percentile(result.tick_ms, 50)),
        "tick_p99_ms": float(np.percentile(result.tick_ms, 99)),
        "script": [(s.duration_s, s.velocity.vx, s.velocity.vy, s.velocity.yaw_rate) for s in script],
    }
