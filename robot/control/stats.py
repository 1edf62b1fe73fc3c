"""Tick-time and real-time-factor statistics of the control loop, cheap enough to update every tick."""

from __future__ import annotations

import time
from collections import deque

import numpy as np

from robot.interface import ControlStats

WINDOW_TICKS = 3000


class LoopStats:
    """Percentiles and max over the last WINDOW_TICKS ticks (30 s at 100 Hz); misses counted since start."""

    def __init__(self, control_hz: float) -> None:
        self.control_hz = control_hz
        self._ticks: deque[float] = deque(maxlen=WINDOW_TICKS)
        self.tick_count = 0
        self.deadline_misses = 0
        self._rtf = 0.0
        self._rtf_wall0 = time.perf_counter()
        self._rtf_sim0 = 0.0
        self._snapshot = ControlStats(control_hz=control_hz)
        self.last_tick_end = time.perf_counter()  # a watchdog compares it with the clock

    def record_tick(self, duration_s: float, missed_deadline: bool) -> None:
        self._ticks.append(duration_s)
        self.tick_count += 1
        if missed_deadline:
            self.deadline_misses += 1
        self.last_tick_end = time.perf_counter()

    def update_rtf(self, sim_time_s: float) -> None:
        """Real-time factor over the last second or so of wall time."""
        now = time.perf_counter()
        elapsed = now - self._rtf_wall0
        if elapsed >= 1.0:
            self._rtf = (sim_time_s - self._rtf_sim0) / elapsed
            self._rtf_wall0, self._rtf_sim0 = now, sim_time_s
            self._refresh()

    def _refresh(self) -> None:
        ticks = np.fromiter(self._ticks, dtype=float) if self._ticks else np.zeros(1)
        self._snapshot = ControlStats(
            tick_p50_ms=float(np.percentile(ticks, 50) * 1e3),
            tick_p99_ms=float(np.percentile(ticks, 99) * 1e3),
            tick_max_ms=float(ticks.max() * 1e3),
            ticks=self.tick_count,
            deadline_misses=self.deadline_misses,
            rtf=self._rtf,
            control_hz=self.control_hz,
        )

    def snapshot(self) -> ControlStats:
        return self._snapshot


class BusTickStats:
    """A real robot's tick split in two: the time spent on the bus (the servos' read and goals, the sensor boards'
    read) and the rest, the tick's compute. Percentiles over the last WINDOW_TICKS ticks."""

    def __init__(self) -> None:
        self._bus: deque[float] = deque(maxlen=WINDOW_TICKS)
        self._compute: deque[float] = deque(maxlen=WINDOW_TICKS)

    def record(self, bus_s: float, tick_s: float) -> None:
        self._bus.append(bus_s)
        self._compute.append(max(0.0, tick_s - bus_s))

    def summary(self) -> dict[str, float]:
        """p50, p99 and max of each, in ms (zeros before the first tick)."""
        out: dict[str, float] = {}
        for name, values in (("bus", self._bus), ("compute", self._compute)):
            ms = np.fromiter(values, dtype=float) * 1e3 if values else np.zeros(1)
            out |= {
                f"{name}_p50_ms": float(np.percentile(ms, 50)),
                f"{name}_p99_ms": float(np.percentile(ms, 99)),
                f"{name}_max_ms": float(ms.max()),
            }
        return out
