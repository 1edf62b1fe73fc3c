"""What is asked of the legs between two ticks, for the control thread to take at the next one: the operator's
teleop velocity (with its deadman), a running plan step's velocity, and a stop without walking off the lag.

The hand-off from plan to legs goes through here (`drive`), not through a shared field.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from robot.control.locomotion import Velocity

# Deadman: teleop motion stops when no teleop command has arrived for this long (s).
TELEOP_TIMEOUT_S = 0.3


class MotionInbox:
    """Velocity requests for the legs. `clock`: the deadman's clock (wall time in real time, simulated time
    headless); `lock`: the robot's state lock."""

    def __init__(self, lock: threading.RLock, clock: Callable[[], float]) -> None:
        self._lock = lock
        self._clock = clock
        self._teleop_active = False
        self._teleop_velocity = Velocity()
        self._teleop_deadline: float | None = None
        self._task_velocity = Velocity()  # what a running plan step asks the legs for
        self._stop_promptly = False  # stop without first walking off the pose loop's lag

    @property
    def teleop_active(self) -> bool:
        return self._teleop_active

    def teleop(self, velocity: Velocity) -> bool:
        """The operator drives (repeat within TELEOP_TIMEOUT_S); True when this starts teleop: a new session, or
        input back after the deadman or a release stopped it (the walk resumes: say so, as at a start)."""
        with self._lock:
            started = not self._teleop_active or self._teleop_deadline is None
            self._teleop_velocity = velocity
            self._teleop_deadline = self._clock() + TELEOP_TIMEOUT_S
            self._teleop_active = True
        return started

    def release_teleop(self) -> bool:
        """The operator let go: stop promptly; True when teleop was active."""
        with self._lock:
            active = self._teleop_active
            self._teleop_velocity, self._teleop_deadline = Velocity(), None
            self._stop_promptly = active
        return active

    def drop_teleop(self) -> None:
        """Forget the operator's velocity and deadline (an e-stop, a reset): the legs get nothing to follow."""
        with self._lock:
            self._teleop_velocity, self._teleop_deadline = Velocity(), None

    def end_teleop(self) -> None:
        """Teleop is over without a stop to walk (a fall, a reset)."""
        with self._lock:
            self._teleop_active = False
            self._teleop_velocity, self._teleop_deadline = Velocity(), None

    def drive(self, velocity: Velocity) -> None:
        """A plan step's velocity for the legs (a deadman too: the step repeats it while it wants motion)."""
        with self._lock:
            self._task_velocity = velocity

    def halt_promptly(self) -> None:
        """A plan step stops the legs where they are, without walking off the lag first."""
        with self._lock:
            self._task_velocity = Velocity()
            self._stop_promptly = True

    def take(self, plan_running: bool, latched: bool) -> tuple[Velocity, bool, bool]:
        """Control thread, each tick: the velocity for the legs (the plan's while one runs, else the operator's;
        none while latched), whether to stop promptly, and whether the deadman just stopped teleop."""
        with self._lock:
            if self._teleop_deadline is not None and self._clock() > self._teleop_deadline:
                self._teleop_velocity, self._teleop_deadline = Velocity(), None
                deadman = self._stop_promptly = True
            else:
                deadman = False
            promptly, self._stop_promptly = self._stop_promptly, False
            velocity = self._task_velocity if plan_running else self._teleop_velocity
        return (Velocity() if latched else velocity), promptly, deadman

    def teleop_ended(self) -> bool:
        """Control thread, once the legs stand still: True (once) when that ends a released teleop session."""
        with self._lock:
            ended = self._teleop_active and self._teleop_deadline is None
            if ended:
                self._teleop_active = False
        return ended
