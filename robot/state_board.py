"""The latest robot state, readable from any thread without locks, and waitable on."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from robot.interface import RobotState


class StateBoard:
    def __init__(self) -> None:
        self._state: RobotState | None = None
        self._changed = threading.Condition()

    def publish(self, state: RobotState) -> None:
        self._state = state  # one reference swap: readers never see a half-written state
        with self._changed:
            self._changed.notify_all()

    def latest(self) -> RobotState:
        if self._state is None:
            raise RuntimeError("no robot state yet: start the worker first")
        return self._state

    def wait_for(self, predicate: Callable[[RobotState], bool], timeout_s: float) -> bool:
        """Block until `predicate(state)` holds or the wall-clock timeout passes."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while not predicate(self.latest()):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                self._changed.wait(min(remaining, 0.1))
        return True
