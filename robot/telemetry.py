"""Telemetry: the robot's motion and key signals sampled at a fixed rate of simulated (or servo) time, for recording
and replay. Sessions replay what the robot did from these samples, and plot its signals, so they are taken by the
control loop itself, on the control clock: a headless run faster than real time is recorded as densely as a live one.

A sample is one flat row of float64 values; `TelemetryLayout` says which columns are which. Rows are kept in a
bounded ring that readers drain by sequence number (`since`), so a slow reader never slows the control loop: it
loses the oldest rows instead, and can tell (`TelemetryBatch.first_seq` jumps).
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass

import numpy as np

# Sampling rate (Hz) the recorder asks for; the control loop takes every n-th tick to get at least this.
DEFAULT_RATE_HZ = 30.0
# Rows kept for readers (a minute at ~33 Hz): the recorder drains them every half second.
RING_ROWS = 2048


@dataclass(frozen=True)
class TelemetryLayout:
    """Named column groups of a telemetry row, in order: (name, width)."""

    fields: tuple[tuple[str, int], ...]
    joint_names: tuple[str, ...]

    @staticmethod
    def for_robot(joint_names: tuple[str, ...], nq: int, n_mocap: int) -> TelemetryLayout:
        n = len(joint_names)
        fields = (
            ("sim_time_s", 1),
            ("wall_time_s", 1),
            ("qpos", nq),  # the whole scene: the robot's free base and joints, and every free object
            ("mocap_pos", 3 * n_mocap),  # kinematic bodies (dropped obstacles)
            ("joint_target", n),
            ("joint_position", n),
            ("joint_velocity", n),
            ("joint_torque", n),
            ("com", 3),  # the robot's centre of mass, world frame
            ("tick_ms", 1),  # how long the control tick that took this sample computed
            ("battery_v", 1),
            ("battery_a", 1),
            ("battery_soc", 1),
        )
        return TelemetryLayout(fields, tuple(joint_names))

    @property
    def width(self) -> int:
        return sum(w for _, w in self.fields)

    def slices(self) -> dict[str, slice]:
        out, start = {}, 0
        for name, w in self.fields:
            out[name] = slice(start, start + w)
            start += w
        return out

    def to_json(self) -> dict:
        return {"fields": [list(f) for f in self.fields], "joint_names": list(self.joint_names)}

    @staticmethod
    def from_json(data: dict) -> TelemetryLayout:
        return TelemetryLayout(tuple((str(n), int(w)) for n, w in data["fields"]), tuple(data["joint_names"]))


@dataclass(frozen=True)
class TelemetryBatch:
    """Consecutive rows: row i is sample number `first_seq + i`."""

    first_seq: int
    rows: np.ndarray  # (n, layout.width) float64

    @property
    def next_seq(self) -> int:
        return self.first_seq + len(self.rows)


class TelemetryRing:
    """The last `capacity` rows, appended by one writer (the control loop) and drained by readers by sequence."""

    def __init__(self, capacity: int = RING_ROWS) -> None:
        self._rows: deque[np.ndarray] = deque(maxlen=capacity)
        self._next_seq = 0
        self._lock = threading.Lock()

    @property
    def next_seq(self) -> int:
        return self._next_seq

    def append(self, row: np.ndarray) -> None:
        with self._lock:
            self._rows.append(row)
            self._next_seq += 1

    def extend(self, batch: TelemetryBatch) -> None:
        """Take rows another ring produced (across the process boundary), keeping their numbering."""
        with self._lock:
            if batch.first_seq != self._next_seq:  # rows were lost on the way: keep the producer's numbering
                self._rows.clear()
            self._rows.extend(batch.rows)
            self._next_seq = batch.next_seq

    def since(self, seq: int) -> TelemetryBatch | None:
        """Rows numbered `seq` and later that are still kept (older ones are gone: the batch starts later)."""
        with self._lock:
            available = len(self._rows)
            first = self._next_seq - available
            start = max(seq, first)
            if start >= self._next_seq:
                return None
            rows = [self._rows[i] for i in range(start - first, available)]
        return TelemetryBatch(start, np.stack(rows))


class TelemetrySampler:
    """Decides which control ticks are sampled (every n-th, n from the control rate) and builds their rows."""

    def __init__(self, layout: TelemetryLayout, control_hz: float, rate_hz: float = DEFAULT_RATE_HZ) -> None:
        self.layout = layout
        self.every = max(1, int(control_hz // rate_hz))
        self.rate_hz = control_hz / self.every
        self.ring = TelemetryRing()
        self._ticks = 0
        self._slices = layout.slices()

    def due(self) -> bool:
        """Called once per control tick: True on the ticks to sample."""
        self._ticks += 1
        return self._ticks % self.every == 0

    def record(self, values: dict[str, float | np.ndarray]) -> None:
        """One row from the layout's fields by name (a field left out is NaN: not measured)."""
        row = np.full(self.layout.width, np.nan)
        for name, value in values.items():
            row[self._slices[name]] = value
        self.ring.append(row)
