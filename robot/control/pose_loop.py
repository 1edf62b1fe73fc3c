"""Outer pose loop: makes the walk go where the velocity command says, not where the gait plan assumes.

Position servos lag and feet slide, so the planned steps alone cover only part of the commanded distance and
drift sideways or in heading. The loop integrates a reference pose from the command and adds the estimated pose
error (in the robot's frame) to the command, as measured in the walking prototype (shared FINDINGS.md: gains
1.0/s, which brought sideways tracking from 30% to about 1%).

- Only while the robot is stepping: during the start (feet still together, ~0.45 s) the reference does not run
  ahead, or the first step would be twice the command (starting sideways that way fell, 3 of 20 scripts).
- When the command drops to zero the remaining lag (a few cm) is walked off for up to `SETTLE_S` before the
  stop, so the stop comes from a slow walk, not from full speed. `release()` skips that (e-stop).
- Standing, the reference follows the estimate: a stop never turns into a walk back to an old reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from robot.control.clamp import clamp
from robot.control.odometry import Pose2D

POSITION_GAIN = 1.0  # 1/s
YAW_GAIN = 1.0  # 1/s
# Errors beyond these are not chased (a push or a slip of this size needs a replan, not a faster walk).
MAX_POSITION_ERROR_M = 0.15
MAX_YAW_ERROR_RAD = 0.4
# After the command stops, the lag is walked off until within these, or for at most SETTLE_S.
SETTLED_M = 0.02
SETTLED_RAD = 0.03
SETTLE_S = 1.5


@dataclass(frozen=True)
class WalkVelocity:
    vx: float
    vy: float
    yaw_rate: float

    @property
    def is_zero(self) -> bool:
        return self.vx == 0.0 and self.vy == 0.0 and self.yaw_rate == 0.0


class PoseLoop:
    def __init__(self, limits: WalkVelocity, backward_limit: float) -> None:
        self._limits = limits
        self._backward = backward_limit
        self.reference: Pose2D | None = None

        self._settling_s = 0.0

    def reset(self, estimate: Pose2D) -> None:
        self.reference = estimate
        self._settling_s = 0.0

    def release(self) -> None:
        """Forget the reference (it is re-anchored on the estimate at the next update)."""
        self.reference = None

    def update(self, command: WalkVelocity, estimate: Pose2D, dt: float, stepping: bool = True) -> WalkVelocity:
        """The velocity to walk at this tick so the estimate follows the integrated command."""
        if not stepping or self.reference is None:
            self.reset(estimate)
            return command
        if command.is_zero:
            self._settling_s += dt
            if self._settling_s > SETTLE_S or self._settled(estimate):
                self.reset(estimate)
                return command
        else:
            self._settling_s = 0.0
        ref = self.reference
        c, s = math.cos(ref.yaw), math.sin(ref.yaw)
        ref = Pose2D(
            ref.x + (c * command.vx - s * command.vy) * dt,
            ref.y + (s * command.vx + c * command.vy) * dt,
            _wrap(ref.yaw + command.yaw_rate * dt),
        )
        ex, ey = ref.x - estimate.x, ref.y - estimate.y
        # a reference running away (robot held, pushed, stalled) is pulled back to a chaseable distance
        distance = math.hypot(ex, ey)
        if distance > MAX_POSITION_ERROR_M:
            k = MAX_POSITION_ERROR_M / distance
            ex, ey = ex * k, ey * k
            ref = Pose2D(estimate.x + ex, estimate.y + ey, ref.yaw)
        eyaw = clamp(_wrap(ref.yaw - estimate.yaw), -MAX_YAW_ERROR_RAD, MAX_YAW_ERROR_RAD)
        ref = Pose2D(ref.x, ref.y, _wrap(estimate.yaw + eyaw))
        self.reference = ref
        c, s = math.cos(estimate.yaw), math.sin(estimate.yaw)
        ex_body, ey_body = c * ex + s * ey, -s * ex + c * ey
        lim = self._limits
        return WalkVelocity(
            clamp(command.vx + POSITION_GAIN * ex_body, -self._backward, lim.vx),
            clamp(command.vy + POSITION_GAIN * ey_body, -lim.vy, lim.vy),
            clamp(command.yaw_rate + YAW_GAIN * eyaw, -lim.yaw_rate, lim.yaw_rate),
        )

    def _settled(self, estimate: Pose2D) -> bool:
        ref = self.reference
        assert ref is not None
        return (
            math.hypot(ref.x - estimate.x, ref.y - estimate.y) < SETTLED_M
            and abs(_wrap(ref.yaw - estimate.yaw)) < SETTLED_RAD
        )


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
