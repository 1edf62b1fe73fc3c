"""The fixed-rate control thread, shared by every body: timing, overruns, priority, and waking early for a stop.

In real time the loop sleeps until each deadline; a `wake()` (an e-stop) cuts the sleep short so the stop is
applied at once, not at the next scheduled tick. Headless it runs as fast as the machine goes, paced only by
`pace` (the simulated sensors keeping their rate in simulated time). A tick that raises does not end the loop:
`on_error` decides what it means (a controller bug latches the e-stop).
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from robot.control.priority import raise_thread_priority
from robot.control.stats import LoopStats
from robot.interface import Level

# When the loop falls this many ticks behind, it stops trying to catch up (sim time would race wall time).
MAX_TICKS_BEHIND = 5


class ControlLoop:
    """Calls `tick` every 1/`hz` s on the "robot-control" thread and keeps its statistics (`stats`).

    `on_wake`: run when `wake()` cuts a sleep short; `pace`: run before each headless tick; `after_tick`: run
    with each tick's duration (book-keeping that must not count in the tick); `guard`: held around each tick and
    wake-up (the real robot's bus lock); `tick_on_wake`: after `on_wake`, tick at once and keep the pace from there
    (a body whose stop reaches its actuators only with a tick: the real robot's goals go out on its bus then)."""

    def __init__(
        self,
        hz: float,
        realtime: bool,
        tick: Callable[[], None],
        on_error: Callable[[Exception], None],
        publish: Callable[..., Any],
        *,
        on_wake: Callable[[], None] | None = None,
        pace: Callable[[], None] | None = None,
        after_tick: Callable[[float], None] | None = None,
        guard: contextlib.AbstractContextManager | None = None,
        stats: LoopStats | None = None,
        tick_on_wake: bool = False,
    ) -> None:
        self.hz = hz
        self.dt = 1.0 / hz
        self.realtime = realtime
        self.stats = stats if stats is not None else LoopStats(hz)
        self._tick = tick
        self._on_error = on_error
        self._publish = publish
        self._on_wake = on_wake
        self._pace = pace
        self._after_tick = after_tick
        self._guard = guard if guard is not None else contextlib.nullcontext()
        self._tick_on_wake = tick_on_wake
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self._thread is not None:
            return
        if self.realtime:
            # the control thread must never wait long for the interpreter lock behind another thread (perception,
            # the task thread): the default switch interval is 5 ms, half a control period
            sys.setswitchinterval(min(sys.getswitchinterval(), 0.0005))
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="robot-control", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        """End the loop after its current tick (nothing else: a body's controlled stop comes before this)."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=timeout_s)
        self._thread = None

    def is_alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    def wake(self) -> None:
        """Cut the current sleep short: `on_wake` runs now on the control thread."""
        self._wake.set()

    def tick_age_s(self) -> float:
        """How long since the last tick ended (the watchdogs' measure of a hung loop)."""
        return time.perf_counter() - self.stats.last_tick_end

    def _run(self) -> None:
        if self.realtime:
            priority = raise_thread_priority()
            level = Level.OK if priority.startswith("real-time") else Level.WARN
            self._publish("control/priority", f"control loop at {self.hz:.0f} Hz with {priority}", level)
        realtime, dt, stats, guard = self.realtime, self.dt, self.stats, self._guard
        next_deadline = time.perf_counter() + dt
        stats.last_tick_end = time.perf_counter()  # the watchdog counts from the loop's start
        while not self._stop.is_set():
            if realtime:
                remaining = next_deadline - time.perf_counter()
                if remaining > 0:
                    if self._wake.wait(remaining):
                        self._wake.clear()
                        if self._on_wake is not None and not self._stop.is_set():
                            with guard:
                                self._on_wake()
                            if self._tick_on_wake:
                                next_deadline = time.perf_counter()
                    continue
            elif self._pace is not None:
                self._pace()
            started = time.perf_counter()
            try:
                with guard:
                    self._tick()
            except Exception as exc:  # the loop must survive a controller bug: `on_error` stops safely and says so
                self._on_error(exc)
            finished = time.perf_counter()
            stats.record_tick(finished - started, realtime and finished > next_deadline + dt)
            if self._after_tick is not None:
                self._after_tick(finished - started)
            next_deadline += dt
            if realtime and finished - next_deadline > MAX_TICKS_BEHIND * dt:
                next_deadline = finished + dt
