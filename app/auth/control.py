"""One operator holds control at a time, and everyone sees who. The first operator to act takes it when it is
free; taking it from another operator is explicit (and said to all). The e-stop needs no control."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from app.auth.roles import Principal, Role

VIEWER_REFUSAL = "viewers may watch and press the e-stop; this needs an operator"


@dataclass(frozen=True)
class ControlHolder:
    name: str
    since: float  # time.time()


class ControlHeld(Exception):
    def __init__(self, holder: ControlHolder) -> None:
        super().__init__(f"{holder.name} has control: take over first")
        self.holder = holder


class ControlLock:
    def __init__(self, on_change: Callable[[str], None] | None = None) -> None:
        self._holder: ControlHolder | None = None
        self._lock = threading.Lock()
        self._on_change = on_change or (lambda message: None)

    @property
    def holder(self) -> ControlHolder | None:
        return self._holder

    def ensure(self, who: Principal) -> None:
        """Before an operator's action: theirs already, or free and now theirs; ControlHeld otherwise."""
        with self._lock:
            if self._holder is not None and self._holder.name != who.name:
                raise ControlHeld(self._holder)
            taken = self._holder is None
            if taken:
                self._holder = ControlHolder(who.name, time.time())
        if taken:
            self._on_change(f"{who.name} has control")

    def take(self, who: Principal, take_over: bool) -> ControlHolder:
        with self._lock:
            previous = self._holder
            if previous is not None and previous.name != who.name and not take_over:
                raise ControlHeld(previous)
            if previous is None or previous.name != who.name:
                self._holder = ControlHolder(who.name, time.time())
            holder = self._holder
        if previous is None:
            self._on_change(f"{who.name} has control")
        elif previous.name != who.name:
            self._on_change(f"{who.name} took control over from {previous.name}")
        return holder

    def release(self, who: Principal) -> bool:
        with self._lock:
            if self._holder is None or self._holder.name != who.name:
                return False
            self._holder = None
        self._on_change(f"{who.name} released control")
        return True


def operator_refusal(control: ControlLock, who: Principal) -> str | None:
    """Why `who` may not command the robot now (None: they may, and have control now, taking it if it was free).
    The one rule for the API, the WebSocket and clicks in the 3D views."""
    if not who.role.allows(Role.OPERATOR):
        return VIEWER_REFUSAL
    try:
        control.ensure(who)
    except ControlHeld as exc:
        return str(exc)
    return None
