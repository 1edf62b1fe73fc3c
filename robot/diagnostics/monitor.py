"""The diagnostics monitor: samples every source about once a second into a `DiagnosticArray`, reports each change
of level as an event (alarms are logged with the session), and calls for a safe stop when a status says motion
is unsafe. A faster watchdog checks that the control loop still ticks."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable

from robot.interface import DiagnosticArray, DiagnosticStatus, Level

log = logging.getLogger(__name__)

Source = Callable[[], Iterable[DiagnosticStatus]]


class DiagnosticsMonitor:
    def __init__(
        self,
        sources: list[Source],
        publish: Callable[..., object],
        safe_stop: Callable[[str], None],
        sim_clock: Callable[[], float],
        period_s: float = 1.0,
        watchdog: Callable[[], DiagnosticStatus | None] | None = None,
        watchdog_period_s: float = 0.05,
    ) -> None:
        """`watchdog` returns a status when something must be caught faster than once a second (a stalled control
        loop), else None; `safe_stop(reason)` brings the robot to its controlled stop."""
        self.sources = sources
        self.publish = publish
        self.safe_stop = safe_stop
        self.sim_clock = sim_clock
        self.period_s = period_s
        self.watchdog = watchdog
        self.watchdog_period_s = watchdog_period_s
        self._lock = threading.Lock()
        self._latest: DiagnosticArray | None = None
        self._levels: dict[str, Level] = {}
        self._stopping: set[str] = set()  # statuses whose fault has stopped the robot and still holds
        self._watchdog_status: DiagnosticStatus | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="robot-diagnostics", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    @property
    def native_thread_id(self) -> int | None:
        """The monitor thread's OS id (what its CPU time is read by)."""
        return self._thread.native_id if self._thread is not None else None

    def latest(self) -> DiagnosticArray | None:
        with self._lock:
            return self._latest

    def unsafe(self) -> list[DiagnosticStatus]:
        """The faults that forbid motion now (the e-stop may not be released while there are any)."""
        latest = self.latest()
        current = [s for s in latest.statuses if s.stops_motion and s.level == Level.ERROR] if latest else []
        with self._lock:
            watchdog = self._watchdog_status
        if watchdog is not None and all(s.name != watchdog.name for s in current):
            current.append(watchdog)
        return current

    def sample(self) -> DiagnosticArray:
        """Sample every source now, report what changed, stop the robot if it must."""
        started = time.thread_time()
        statuses: list[DiagnosticStatus] = []
        for source in self.sources:
            try:
                statuses.extend(source())
            except Exception as exc:  # one broken source must not blind the others
                name = getattr(source, "__qualname__", repr(source))
                log.exception("diagnostics source %s failed", name)
                statuses.append(DiagnosticStatus("diagnostics/monitor", Level.WARN, f"{name} failed: {exc!r}"))
        with self._lock:
            watchdog = self._watchdog_status
        if watchdog is not None:
            statuses = [s for s in statuses if s.name != watchdog.name] + [watchdog]
        array = DiagnosticArray(time.time(), self.sim_clock(), tuple(statuses), (time.thread_time() - started) * 1e3)
        with self._lock:
            self._latest = array
        self._report(statuses)
        return array

    def _report(self, statuses: list[DiagnosticStatus]) -> None:
        for status in statuses:
            previous = self._levels.get(status.name, Level.OK)
            self._levels[status.name] = status.level
            if status.level != previous:
                if status.level == Level.OK:
                    self.publish(
                        "diagnostics/recovered",
                        f"{status.name}: OK again ({status.message})",
                        Level.OK,
                        name=status.name,
                        previous=previous.name,
                    )
                else:
                    self.publish(
                        "diagnostics/alarm",
                        f"{status.name} {status.level.name}: {status.message}",
                        status.level,
                        name=status.name,
                        values=dict(status.values),
                    )
            unsafe = status.stops_motion and status.level == Level.ERROR
            if unsafe and status.name not in self._stopping:
                self._stopping.add(status.name)
                self.safe_stop(f"{status.name}: {status.message}")
            elif not unsafe:
                self._stopping.discard(status.name)

    def _check_watchdog(self) -> None:
        if self.watchdog is None:
            return
        status = self.watchdog()
        with self._lock:
            was = self._watchdog_status
            self._watchdog_status = status
        if (status is None) != (was is None):
            self.sample()  # report (and act on) the change now, not at the next second

    def _run(self) -> None:
        next_sample = time.monotonic()
        while not self._stop.is_set():
            try:
                self._check_watchdog()
                if time.monotonic() >= next_sample:
                    next_sample = max(next_sample + self.period_s, time.monotonic())
                    self.sample()
            except Exception:  # the monitor must outlive any bug of its own
                log.exception("diagnostics monitor failed")
            self._stop.wait(self.watchdog_period_s if self.watchdog is not None else self.period_s)
