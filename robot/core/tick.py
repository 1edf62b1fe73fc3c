"""One control period, the same for every body: a latched stop applied, a reset done, the body's requests served;
then measurements in, joint targets from whoever owns the joints, targets out (the physics forward), a fall
noticed, the state published. It is the loop's `tick`; its `on_wake` applies a stop between ticks.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.control.locomotion import LocomotionController
from robot.control.stack import measured_pose, sensors
from robot.control.stats import LoopStats
from robot.core.arbiter import JointArbiter
from robot.core.body import Body, BodySnapshot, Diverged
from robot.core.inbox import MotionInbox
from robot.core.publisher import StatePublisher
from robot.core.safety import SafetyLatch
from robot.interface import EStop, Level

log = logging.getLogger(__name__)


class ControlTick:
    """`wake`: cut the loop's sleep short (a reset asked between ticks); `on_fall(reason)`, `on_reset_requested()`
    and `on_reset()` tell the other units (the running plan fails with the fall, plans and teleop stop for a reset,
    the hand lets go of what it held)."""

    def __init__(
        self,
        body: Body,
        lock: threading.RLock,
        latch: SafetyLatch,
        arbiter: JointArbiter,
        publisher: StatePublisher,
        stats: LoopStats,
        publish: Callable[..., Any],
        wake: Callable[[], None],
        *,
        inbox: MotionInbox | None = None,
        locomotion: LocomotionController | None = None,
        on_fall: Callable[[str], None] = lambda reason: None,
        on_reset_requested: Callable[[], None] = lambda: None,
        on_reset: Callable[[], None] = lambda: None,
    ) -> None:
        self._body = body
        self._lock = lock
        self._latch = latch
        self._arbiter = arbiter
        self._publisher = publisher
        self._stats = stats
        self._publish = publish
        self._wake = wake
        self._inbox = inbox
        self._loco = locomotion
        self._on_fall = on_fall
        self._on_reset_requested = on_reset_requested
        self._on_reset = on_reset
        self._reset_pending = False
        # a robot that was not placed when built (the real one: its bus opens at start) starts the legs' estimate
        # from its start pose at its first IMU reading
        self._placed = locomotion is None or body.connected
        self._last_error: tuple[str, float] = ("", 0.0)  # what the last failing tick said, and when

    def tick(self) -> None:
        body = self._body
        body.before_tick()
        self._apply_stop()
        if self._reset_pending:
            self._apply_reset()
        body.apply_requests()
        measured = body.sense()
        if not self._placed and self._loco is not None and np.isfinite(measured.imu_quat).all():
            self._loco.reset_odometry(measured_pose(measured), sensors(measured))
            self._placed = True
        targets = self._arbiter.targets(measured)
        try:
            measured = body.actuate(targets)
        except Diverged as exc:
            self._diverged(exc)
            return
        self._stats.update_rtf(measured.sim_time_s)
        snapshot = body.snapshot(measured)
        if snapshot.fallen and not self._latch.fallen:
            self._fell(snapshot)
        self._publisher.publish(measured, snapshot)

    def on_wake(self) -> None:
        """Between ticks: a latched stop is applied now, not at the next tick (nor a reset)."""
        self._apply_stop()
        if self._reset_pending:
            self._apply_reset()

    def after_tick(self, tick_s: float) -> None:
        self._body.after_tick(self._arbiter.commanded, tick_s)

    # ---------------------------------------------------------------------------------------------------------
    # stops, falls, resets

    def _apply_stop(self) -> None:
        """The controlled stop: every joint holds its current reference (a walk first ends its step), or the
        body's stop posture; the operator's velocity is dropped."""
        pending = self._latch.take_pending()
        if pending is None:
            return
        command, received = pending
        if self._inbox is not None:
            self._inbox.drop_teleop()
        walking, hold = self._arbiter.controlled_stop()
        if hold is not None:
            self._body.hold_now(hold)
        self._body.stop_applied()
        self._latch.announce(command, received, self._body.stop_action(walking))
        self._publisher.publish(self._body.latest())

    def _fell(self, snapshot: BodySnapshot) -> None:
        self._arbiter.fell()
        reason = f"fell (tilt {snapshot.tilt_deg:.0f} deg)"
        with self._lock:
            self._latch.fall()
            if self._inbox is not None:
                self._inbox.end_teleop()
            self._on_fall(reason)
        self._publish(
            "robot/fell",
            f"the robot fell (tilt {snapshot.tilt_deg:.0f} deg)",
            Level.ERROR,
            tilt_deg=snapshot.tilt_deg,
            height_m=float(snapshot.base_position[2]),
        )

    @property
    def reset_pending(self) -> bool:
        return self._reset_pending

    def request_reset(self) -> None:
        """Stand the robot up again at its start pose, at the next tick (the caller has stopped what moved it)."""
        with self._lock:
            self._reset_pending = True
            self._on_reset_requested()
        self._wake()

    def _apply_reset(self) -> None:
        """Control thread: the robot stands again at its start pose, as after start-up."""
        with self._lock:
            if not self._reset_pending:
                return
            self._reset_pending = False
            self._latch.stand_up()
            if self._inbox is not None:
                self._inbox.end_teleop()
            self._on_reset()
        stand = self._arbiter.reset()
        measured = self._body.reset(stand)
        if self._loco is not None:
            self._loco.reset_odometry(measured_pose(measured), sensors(measured))
        self._publish("robot/reset", "robot reset: standing at its start pose")

    def _diverged(self, exc: Diverged) -> None:
        """The physics reset the scene by itself: the robot is stopped, then stood up again at its start pose."""
        log.error("%s: e-stop latched, robot reset to its start pose", exc)
        self._publish("sim/diverged", f"{exc}: e-stop latched, robot reset to its start pose", Level.ERROR)
        self._latch.latch(EStop(source="sim-diverged", reason=str(exc)))
        self.request_reset()

    def on_error(self, exc: Exception) -> None:
        """A failing tick latches the e-stop; said once, and again only when it changes or a second later (a bug
        that fails every tick must not flood the events at 100 Hz). A body may deal with its own errors."""
        if self._body.tick_error(exc):
            return
        text, at = self._last_error
        now = time.monotonic()
        if repr(exc) != text or now - at > 1.0:
            self._last_error = (repr(exc), now)
            log.error("control tick failed", exc_info=exc)
            self._publish("control/error", f"control tick failed: {exc!r}", Level.ERROR, error=repr(exc))
        if not self._latch.latched:
            self._latch.latch(EStop(source="control-error", reason=f"the control tick failed: {exc!r}"))
