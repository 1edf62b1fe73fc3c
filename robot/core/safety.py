"""The safety latch: the e-stop (latched, then applied by the control thread), the fall, and the rules for letting
go: released only by the operator, only once the stop has been applied, and only when diagnostics find nothing
that makes motion unsafe. Every unit that moves the robot asks `refusal()` first.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robot.interface import CommandReply, DiagnosticStatus, EStop, Level, Refusal, ReleaseEStop


@dataclass(frozen=True)
class LatchWords:
    """What the operator is told, which depends on what the body's controlled stop does."""

    latched: str = "e-stop latched"
    already_latched: str = "e-stop already latched"
    released: str = "the robot stays still until the next command"
    release_reply: str = "e-stop released; send a command or replan to resume"


class SafetyLatch:
    """Latched by anyone (`latch`), applied by the control thread (`take_pending`), released by the operator.

    `lock`: the robot's state lock, shared with the units whose state must change together with the latch (a
    plan queued just as the e-stop latches is cancelled, never started). `on_latch` hooks run under it."""

    def __init__(
        self,
        lock: threading.RLock,
        publish: Callable[..., Any],
        unsafe: Callable[[], Sequence[DiagnosticStatus]] = tuple,
        words: LatchWords = LatchWords(),
    ) -> None:
        self._lock = lock
        self._publish = publish
        self._unsafe = unsafe
        self.words = words
        self._latched = False
        self._pending: tuple[EStop, float] | None = None  # latched, not yet applied by the control thread
        self._cause = ""  # who latched it, and why: "diagnostics: servos/r_knee: ..."
        self._fallen = False
        self._on_latch: list[Callable[[], None]] = []
        self._on_release: list[Callable[[], None]] = []

    def on_latch(self, hook: Callable[[], None]) -> None:
        """Run `hook` (under the lock) each time the latch closes: cancel plans, wake the control loop."""
        self._on_latch.append(hook)

    def on_release(self, hook: Callable[[], None]) -> None:
        self._on_release.append(hook)

    @property
    def latched(self) -> bool:
        return self._latched

    @property
    def fallen(self) -> bool:
        return self._fallen

    @property
    def cause(self) -> str:
        """Who latched the stop last, and why if it was not a person ("diagnostics: ..."): said where it ends work."""
        return self._cause

    def latch(self, command: EStop) -> CommandReply:
        received = time.time()
        with self._lock:
            if self._latched:
                return CommandReply(True, self.words.already_latched)
            self._latched = True
            self._pending = (command, received)
            self._cause = f"{command.source}: {command.reason}" if command.reason else command.source
            for hook in self._on_latch:
                hook()
        return CommandReply(True, self.words.latched)

    def take_pending(self) -> tuple[EStop, float] | None:
        """Control thread: the latched stop to apply now (once), with when it was received."""
        if self._pending is None:  # the common case, every tick: no lock
            return None
        with self._lock:
            pending, self._pending = self._pending, None
        return pending

    def announce(self, command: EStop, received: float, action: str) -> None:
        """Say the stop was applied (`action`: what the body does), with how long it took from each hop."""
        applied = time.time()
        data: dict[str, Any] = {"source": command.source, "worker_latency_ms": (applied - received) * 1e3}
        if command.relayed_at_s is not None:
            data["server_latency_ms"] = (applied - command.relayed_at_s) * 1e3
        if command.client_time_s is not None:
            data["latency_ms"] = (applied - command.client_time_s) * 1e3
        why = f" because {command.reason}" if command.reason else ""
        if command.reason:
            data["reason"] = command.reason
        self._publish("estop/latched", f"E-STOP latched ({command.source}){why}: {action}", Level.ERROR, **data)

    def release(self, command: ReleaseEStop) -> CommandReply:
        with self._lock:
            if not self._latched:
                return CommandReply(False, "e-stop is not latched", Refusal.NOT_LATCHED)
            if self._pending is not None:
                return CommandReply(False, "e-stop is still being applied; try again", Refusal.ESTOP_LATCHED)
            unsafe = self._unsafe()
            if unsafe:
                faults = "; ".join(f"{s.name}: {s.message}" for s in unsafe)
                return CommandReply(False, f"motion is unsafe until this is fixed: {faults}", Refusal.ESTOP_LATCHED)
            self._latched = False
            for hook in self._on_release:
                hook()
        self._publish("estop/released", f"E-STOP released ({command.source}); {self.words.released}")
        return CommandReply(True, self.words.release_reply)

    def refusal(self) -> CommandReply | None:
        """Why the robot may not be asked to move now (None: it may)."""
        if self._latched:
            return CommandReply(False, "e-stop is latched: release it first", Refusal.ESTOP_LATCHED)
        if self._fallen:
            return CommandReply(False, "the robot has fallen: it must be reset first", Refusal.ESTOP_LATCHED)
        return None

    def fall(self) -> None:
        self._fallen = True

    def stand_up(self) -> None:
        """The robot was put back on its feet (a reset)."""
        self._fallen = False

    def safe_stop(self, reason: str) -> None:
        """Diagnostics found a fault that makes motion unsafe: the controlled stop, latched."""
        if self._fallen:  # already down and refusing to move
            return
        self._publish("diagnostics/safe_stop", f"safe stop: {reason}", Level.ERROR, reason=reason)
        self.latch(EStop(source="diagnostics", reason=reason))
