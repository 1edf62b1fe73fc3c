"""The operator's motion commands: teleop (with its deadman in the motion inbox), letting go, and postures. Each
is refused with its reason when the robot may not move, or is busy with something that owns the joints."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.control.locomotion import LocomotionController, Velocity, clip_velocity
from robot.core.arbiter import JointArbiter
from robot.core.inbox import MotionInbox
from robot.core.safety import SafetyLatch
from robot.interface import CommandReply, Posture, Refusal, SetPosture, StopTeleop, Teleop


class MotionCommands:
    """`body_refusal`: why the body cannot move now (torque off); `crouch`: the crouching posture's joint targets;
    `plan_running` and `plans_busy`: a plan runs (or waits to); `reset_pending`: the robot is being reset. Without
    legs (no locomotion, no inbox) only postures are served."""

    def __init__(
        self,
        lock: threading.RLock,
        latch: SafetyLatch,
        arbiter: JointArbiter,
        publish: Callable[..., Any],
        crouch: np.ndarray,
        body_refusal: Callable[[], CommandReply | None],
        *,
        inbox: MotionInbox | None = None,
        locomotion: LocomotionController | None = None,
        plan_running: Callable[[], bool] = lambda: False,
        plans_busy: Callable[[], bool] = lambda: False,
        reset_pending: Callable[[], bool] = lambda: False,
    ) -> None:
        self._lock = lock
        self._latch = latch
        self._inbox = inbox
        self._arbiter = arbiter
        self._loco = locomotion
        self._publish = publish
        self._crouch = crouch
        self._body_refusal = body_refusal
        self._plan_running = plan_running
        self._plans_busy = plans_busy
        self._reset_pending = reset_pending

    def teleop_refusal(self) -> CommandReply | None:
        if self._inbox is not None and self._inbox.teleop_active:
            return CommandReply(False, "teleop is active: release the controls before running a plan", Refusal.BUSY)
        return None

    def teleop(self, command: Teleop) -> CommandReply:
        assert self._inbox is not None and self._loco is not None, "teleop needs legs"
        try:
            velocity = clip_velocity(Velocity(command.vx, command.vy, command.yaw_rate), self._loco.velocity.limits)
        except (TypeError, ValueError):
            return CommandReply(False, "teleop velocity must be finite numbers", Refusal.INVALID)
        with self._lock:
            if refusal := self._latch.refusal():
                return refusal
            if self._plans_busy():
                return CommandReply(False, "a plan is running: cancel it to teleoperate", Refusal.BUSY)
            if self._reset_pending():
                return CommandReply(False, "the robot is being reset", Refusal.BUSY)
            started = self._inbox.teleop(velocity)
            self._arbiter.to_standing()
        if started:
            self._publish("teleop/started", f"teleop started ({command.source})", source=command.source)
        v = velocity
        return CommandReply(True, f"teleop vx {v.vx:.2f} m/s, vy {v.vy:.2f} m/s, yaw rate {v.yaw_rate:.2f} rad/s")

    def stop_teleop(self, command: StopTeleop) -> CommandReply:
        assert self._inbox is not None, "teleop needs legs"
        active = self._inbox.release_teleop()
        if active:
            self._publish("teleop/stop", f"teleop stopped ({command.source}): stopping", source=command.source)
        return CommandReply(True, "stopping" if active else "teleop is not active")

    def set_posture(self, command: SetPosture) -> CommandReply:
        posture = command.posture
        with self._lock:
            if refusal := self._latch.refusal() or self._body_refusal() or self.teleop_refusal():
                return refusal
            if self._plan_running():
                return CommandReply(False, "a plan is running: cancel it first", Refusal.BUSY)
            if self._loco is not None and self._loco.moving:
                return CommandReply(False, "the robot is walking: stop it first", Refusal.BUSY)
            if self._arbiter.arm_active:
                return CommandReply(False, "the arm is still moving: try again in a moment", Refusal.BUSY)
            goal = self._arbiter.stand if posture == Posture.STAND else self._crouch
            self._arbiter.set_posture(posture, goal)
        self._publish("posture/set", f"moving to the {posture.value} posture", posture=posture.value)
        return CommandReply(True, f"moving to the {posture.value} posture")
