"""Locomotion: a velocity command in, joint targets out, with balance feedback from the IMU.

Composes the walking state machine (placo gait + whole-body IK) and the ankle balance strategy behind the
velocity interface the rest of the system uses: (vx, vy, yaw rate) in the robot's frame, clipped to the limits
and rate-limited so commands from a joystick or a path follower never jerk the robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot.control.balance import AnkleBalance
from robot.control.gait import SINGLE_SUPPORT_S, StepCommand
from robot.control.walking import GaitPlanner, WalkingController, WalkPhase
from robot.control.whole_body import WholeBodyIK


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


class VelocityShaper:
    """Clips a velocity command to the limits and moves towards it at bounded acceleration."""

    def __init__(self, limits: VelocityLimits = VelocityLimits()) -> None:
        self.limits = limits
        self._target = Velocity()
        self.current = Velocity()

    def set_target(self, command: Velocity) -> Velocity:
        """Store the clipped command; returns it so callers can report what was accepted."""
        lim = self.limits
        values = np.array([command.vx, command.vy, command.yaw_rate], dtype=float)
        if not np.all(np.isfinite(values)):
            raise ValueError("velocity command must be finite")
        self._target = Velocity(
            float(np.clip(command.vx, -lim.vx_backward, lim.vx_forward)),
            float(np.clip(command.vy, -lim.vy, lim.vy)),
            float(np.clip(command.yaw_rate, -lim.yaw_rate, lim.yaw_rate)),
        )
        return self._target

    def update(self, dt: float) -> Velocity:
        lim, cur, tgt = self.limits, self.current, self._target
        dv, dw = lim.accel * dt, lim.yaw_accel * dt
        self.current = Velocity(
            cur.vx + float(np.clip(tgt.vx - cur.vx, -dv, dv)),
            cur.vy + float(np.clip(tgt.vy - cur.vy, -dv, dv)),
            cur.yaw_rate + float(np.clip(tgt.yaw_rate - cur.yaw_rate, -dw, dw)),
        )
        return self.current


class LocomotionController:
    def __init__(
        self, planner: GaitPlanner, ik: WholeBodyIK, balance: AnkleBalance, dt: float, limits=VelocityLimits()
    ) -> None:
        self.walking = WalkingController(planner, ik, dt)
        self.balance = balance
        self.velocity = VelocityShaper(limits)
        self.dt = dt

    @property
    def stand_targets(self) -> np.ndarray:
        """The posture walking starts from and ends in."""
        return self.walking.ready_targets

    @property
    def phase(self) -> WalkPhase:
        return self.walking.phase

    def set_velocity(self, command: Velocity) -> Velocity:
        return self.velocity.set_target(command)

    def stop(self) -> None:
        self.velocity.set_target(Velocity())

    def update(self, imu_quat: np.ndarray, imu_gyro: np.ndarray, hold: np.ndarray) -> np.ndarray:
        """Joint targets for this tick; `hold` is what to command while not walking (the current posture)."""
        v = self.velocity.update(self.dt)
        self.walking.set_step_command(
            StepCommand(v.vx * SINGLE_SUPPORT_S, v.vy * SINGLE_SUPPORT_S, v.yaw_rate * SINGLE_SUPPORT_S)
        )
        targets = self.walking.update()
        return self.balance.correct(hold if targets is None else targets, imu_quat, imu_gyro)
