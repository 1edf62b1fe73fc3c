"""Locomotion: a velocity command in, joint targets out, with balance feedback from the IMU.

Composes the walking state machine (placo gait + whole-body IK) and the ankle balance strategy behind the
velocity interface the rest of the system uses: (vx, vy, yaw rate) in the robot's frame, clipped to the limits
and rate-limited so commands from a joystick or a path follower never jerk the robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robot.control.balance import AnkleBalance
from robot.control.clamp import clamp
from robot.control.gait import (
    MAX_STEP_BACKWARD_M,
    MAX_STEP_FORWARD_M,
    MAX_STEP_SIDE_M,
    MAX_STEP_TURN_RAD,
    SINGLE_SUPPORT_S,
    StepCommand,
)
from robot.control.odometry import LegOdometry, Pose2D
from robot.control.pose_loop import PoseLoop, WalkVelocity
from robot.control.walking import GaitPlanner, PlanLateness, WalkingController, WalkPhase
from robot.control.whole_body import WholeBodyIK

# A foot carrying more than this (N) is on the ground, whatever the plan says.
SWING_FOOT_LOADED_N = 3.0


@dataclass(frozen=True)
class VelocityLimits:
    vx_forward: float = 0.20  # m/s
    vx_backward: float = 0.13
    vy: float = 0.05
    yaw_rate: float = 1.0  # rad/s
    accel: float = 0.3  # m/s^2
    yaw_accel: float = 1.5  # rad/s^2


@dataclass(frozen=True)
class Velocity:
    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0


def clip_velocity(command: Velocity, limits: VelocityLimits) -> Velocity:
    """`command` within the limits; ValueError if it is not finite."""
    if not all(math.isfinite(v) for v in (command.vx, command.vy, command.yaw_rate)):
        raise ValueError("velocity command must be finite")
    return Velocity(
        clamp(command.vx, -limits.vx_backward, limits.vx_forward),
        clamp(command.vy, -limits.vy, limits.vy),
        clamp(command.yaw_rate, -limits.yaw_rate, limits.yaw_rate),
    )


class VelocityShaper:
    """Clips a velocity command to the limits and moves towards it at bounded acceleration."""

    def __init__(self, limits: VelocityLimits = VelocityLimits()) -> None:
        self.limits = limits
        self.target = Velocity()
        self.current = Velocity()

    def set_target(self, command: Velocity) -> Velocity:
        """Store the clipped command; returns it so callers can report what was accepted."""
        self.target = clip_velocity(command, self.limits)
        return self.target

    def update(self, dt: float) -> Velocity:
        lim, cur, tgt = self.limits, self.current, self.target
        dv, dw = lim.accel * dt, lim.yaw_accel * dt
        self.current = Velocity(
            cur.vx + clamp(tgt.vx - cur.vx, -dv, dv),
            cur.vy + clamp(tgt.vy - cur.vy, -dv, dv),
            cur.yaw_rate + clamp(tgt.yaw_rate - cur.yaw_rate, -dw, dw),
        )
        return self.current


@dataclass(frozen=True)
class GaitOverlay:
    """What the 3D mirror draws of the walk, in the world frame: footsteps ahead, CoM and ZMP, support foot."""

    phase: str
    footsteps: tuple[tuple[str, float, float, float], ...]  # (side, x, y, yaw)
    com: tuple[float, float, float]
    zmp: tuple[float, float]
    support: str


@dataclass(frozen=True)
class LegSensors:
    """What locomotion reads each tick: encoders, IMU and foot force pads (as real servos and sensors give)."""

    joint_positions: np.ndarray
    imu_quat: np.ndarray
    imu_gyro: np.ndarray
    foot_forces: np.ndarray


class LocomotionController:
    """Velocity command in, joint targets out.

    The shaped command goes through the outer pose loop (leg odometry + IMU heading), becomes a per-step
    displacement for the gait planner, and the walk's joint targets get the IMU ankle correction.
    """

    def __init__(
        self,
        planner: GaitPlanner,
        ik: WholeBodyIK,
        balance: AnkleBalance,
        dt: float,
        odometry: LegOdometry,
        limits: VelocityLimits = VelocityLimits(),
        pose_loop: bool = True,
        wait_for_plans: bool = True,
    ) -> None:
        self.walking = WalkingController(planner, ik, dt, wait_for_plans)
        self.balance = balance
        self.velocity = VelocityShaper(limits)
        self.odometry = odometry
        s = SINGLE_SUPPORT_S  # the pose loop may ask for up to the gait's largest steps
        gait_limits = WalkVelocity(MAX_STEP_FORWARD_M / s, MAX_STEP_SIDE_M / s, MAX_STEP_TURN_RAD / s)
        self._pose_loop = PoseLoop(gait_limits, MAX_STEP_BACKWARD_M / s)
        self._use_pose_loop = pose_loop
        self.dt = dt

    @property
    def stand_targets(self) -> np.ndarray:
        """The posture walking starts from and ends in."""
        return self.walking.ready_targets

    @property
    def phase(self) -> WalkPhase:
        return self.walking.phase

    @property
    def plan_lateness(self) -> PlanLateness:
        """Walk plans that came after they were due (real time on a busy machine)."""
        return self.walking.lateness

    @property
    def moving(self) -> bool:
        """True while walking or asked to walk: the joints belong to locomotion."""
        v = self.velocity
        return self.walking.active or not _is_zero(v.current) or not _is_zero(v.target)

    def set_velocity(self, command: Velocity) -> Velocity:
        return self.velocity.set_target(command)

    def stop(self, promptly: bool = False) -> None:
        """Decelerate to a stop (two steps in place, then stand); `promptly` also drops the position lag the
        pose loop would otherwise walk off first (e-stop)."""
        self.velocity.set_target(Velocity())
        if promptly:
            self._pose_loop.release()

    def halt(self) -> None:
        """Stop commanding motion at once (e-stop, fall, reset): the caller takes over the joints."""
        self.velocity.set_target(Velocity())
        self.velocity.current = Velocity()
        self.walking.abort()

    def reset_odometry(self, pose: Pose2D, sensors: LegSensors) -> None:
        self.odometry.reset(pose, sensors.joint_positions, sensors.imu_quat)
        self._pose_loop.reset(self.odometry.pose)

    def update(self, sensors: LegSensors, hold: np.ndarray) -> np.ndarray:
        """Joint targets for this tick; `hold` is what to command while not walking (the current posture)."""
        estimate = self.odometry.update(sensors.joint_positions, sensors.imu_quat, sensors.foot_forces)
        v = self.velocity.update(self.dt)
        command = WalkVelocity(v.vx, v.vy, v.yaw_rate)
        if self._use_pose_loop:
            stepping = self.walking.stepped and self.walking.phase in (WalkPhase.WALKING, WalkPhase.STOPPING)
            command = self._pose_loop.update(command, estimate, self.dt, stepping)
        s = SINGLE_SUPPORT_S
        self.walking.set_step_command(StepCommand(command.vx * s, command.vy * s, command.yaw_rate * s))
        targets = self.walking.update()
        if targets is None:
            return self.balance.correct(hold, sensors.imu_quat, sensors.imu_gyro)
        swing = self.walking.swing_leg()
        if swing is not None and float(np.sum(sensors.foot_forces[0 if swing == "left" else 1])) > SWING_FOOT_LOADED_N:
            swing = None  # a planned swing foot still (or already) on the ground pushes the body: do not level it
        # carrying something (the arm held out), the stance-leg levelling shook the hand: an apple slipped out of it
        level = self.walking.ik.arms_at_rest
        return self.balance.correct(targets, sensors.imu_quat, sensors.imu_gyro, swing, level_stance=level)

    def overlay(self) -> GaitOverlay | None:
        """The walk in the world frame, placed by the current pose estimate; None while standing."""
        view = self.walking.view()
        if view is None:
            return None
        # planner frame -> world: the model root's planned pose maps onto its estimated pose
        planned = self.walking.ik.robot.get_T_world_fbase()
        p_yaw = math.atan2(planned[1, 0], planned[0, 0])
        est = self.odometry.pose
        dyaw = est.yaw - p_yaw
        c, s_ = math.cos(dyaw), math.sin(dyaw)

        def to_world(x: float, y: float) -> tuple[float, float]:
            dx, dy = x - planned[0, 3], y - planned[1, 3]
            return (est.x + c * dx - s_ * dy, est.y + s_ * dx + c * dy)

        steps = tuple((f.side, *to_world(f.x, f.y), f.yaw + dyaw) for f in view.footsteps)
        cx, cy = to_world(view.com[0], view.com[1])
        zx, zy = to_world(view.zmp[0], view.zmp[1])
        return GaitOverlay(view.phase.value, steps, (cx, cy, view.com[2]), (zx, zy), view.support_foot)


def _is_zero(v: Velocity) -> bool:
    return v.vx == 0.0 and v.vy == 0.0 and v.yaw_rate == 0.0
