"""RGB-D frames over a stream socket: how the hardware-in-the-loop rig's head camera reaches the robot's process,
where they are injected into librealsense's own software device (`realsense_rig.RigFrameSource`). A frame is a
header (seq, stamp, size, pinhole intrinsics), the colour image (RGB, 8 bits) and the depth (mm, 16 bits)."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

from robot.perception.geometry import PinholeIntrinsics

MAGIC = b"RGBD"
HEADER = struct.Struct("<4sIdHHdddd")  # magic, seq, stamp (s), width, height, fx, fy, cx, cy
DEPTH_M_PER_COUNT = 0.001


@dataclass(frozen=True)
class RgbdFrame:
    seq: int
    stamp_s: float
    rgb: np.ndarray  # (H, W, 3) uint8
    depth_m: np.ndarray  # (H, W) float32, 0: no return
    intrinsics: PinholeIntrinsics


def encode_frame(frame: RgbdFrame) -> bytes:
    i = frame.intrinsics
    counts = np.clip(np.round(frame.depth_m / DEPTH_M_PER_COUNT), 0, 65535).astype("<u2")
    header = HEADER.pack(MAGIC, frame.seq, frame.stamp_s, i.width, i.height, i.fx, i.fy, i.cx, i.cy)
    return header + np.ascontiguousarray(frame.rgb, dtype=np.uint8).tobytes() + counts.tobytes()


def read_frame(stream: BinaryIO) -> RgbdFrame | None:
    """The next frame, or None at the end of the stream. ValueError for a stream that is not frames."""
    head = stream.read(HEADER.size)
    if len(head) < HEADER.size:
        return None
    magic, seq, stamp, width, height, fx, fy, cx, cy = HEADER.unpack(head)
    if magic != MAGIC or not (0 < width <= 4096 and 0 < height <= 4096):
        raise ValueError(f"not an RGB-D frame stream (header {head[:8]!r})")
    size = width * height
    body = stream.read(size * 5)
    if len(body) < size * 5:
        return None
    rgb = np.frombuffer(body[: size * 3], dtype=np.uint8).reshape(height, width, 3)
    depth = np.frombuffer(body[size * 3 :], dtype="<u2").reshape(height, width).astype(np.float32) * DEPTH_M_PER_COUNT
    return RgbdFrame(seq, stamp, rgb, depth, PinholeIntrinsics(width, height, fx, fy, cx, cy))
