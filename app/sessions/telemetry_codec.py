"""How telemetry rows are stored: a chunk of rows as one compressed blob.

The first two columns of every layout are the simulated and the wall-clock time; they stay float64 (a wall time of
1.8e9 s in float32 would be 2 minutes coarse). The rest is float32 (0.1 um on a 10 m floor), byte-shuffled before
zlib (the same byte of neighbouring values compresses together): about 0.8 MB per minute of walking at 33 Hz.

Format 1: b"HTC1", rows (uint32), width (uint32), then zlib of times (rows x 2 float64) and shuffled values
(rows x (width - 2) float32), all little-endian. Changing it needs a new format tag and a migration.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

MAGIC = b"HTC1"
_HEADER = struct.Struct("<4sII")
TIME_COLUMNS = 2  # sim_time_s, wall_time_s
ZLIB_LEVEL = 6


class CorruptChunk(ValueError):
    """A stored chunk that cannot be decoded (wrong format, truncated, or not of this layout)."""


def encode_rows(rows: np.ndarray) -> bytes:
    rows = np.asarray(rows, dtype=float)
    if rows.ndim != 2 or rows.shape[1] < TIME_COLUMNS:
        raise ValueError(f"telemetry rows must be (n, width >= {TIME_COLUMNS}), not {rows.shape}")
    n, width = rows.shape
    times = np.ascontiguousarray(rows[:, :TIME_COLUMNS], dtype="<f8")
    values = np.ascontiguousarray(rows[:, TIME_COLUMNS:], dtype="<f4")
    shuffled = values.view(np.uint8).reshape(n, -1, 4).transpose(2, 1, 0).tobytes()
    return _HEADER.pack(MAGIC, n, width) + zlib.compress(times.tobytes() + shuffled, ZLIB_LEVEL)


def decode_rows(blob: bytes) -> np.ndarray:
    """The (n, width) float64 rows of a chunk."""
    if len(blob) < _HEADER.size:
        raise CorruptChunk("telemetry chunk too short")
    magic, n, width = _HEADER.unpack_from(blob)
    if magic != MAGIC or width < TIME_COLUMNS:
        raise CorruptChunk(f"not a telemetry chunk of format 1 ({magic!r})")
    try:
        raw = zlib.decompress(blob[_HEADER.size :])
    except zlib.error as exc:
        raise CorruptChunk(f"telemetry chunk does not decompress: {exc}") from exc
    n_values = width - TIME_COLUMNS
    if len(raw) != n * (TIME_COLUMNS * 8 + n_values * 4):
        raise CorruptChunk("telemetry chunk has the wrong length for its header")
    split = n * TIME_COLUMNS * 8
    times = np.frombuffer(raw[:split], dtype="<f8").reshape(n, TIME_COLUMNS)
    values = np.frombuffer(raw[split:], dtype=np.uint8).reshape(4, n_values, n).transpose(2, 1, 0)
    out = np.empty((n, width))
    out[:, :TIME_COLUMNS] = times
    out[:, TIME_COLUMNS:] = np.ascontiguousarray(values).view("<f4").reshape(n, n_values)
    return out
