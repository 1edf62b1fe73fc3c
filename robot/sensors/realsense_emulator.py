"""A RealSense as librealsense itself emulates one: a `software_device` with a depth and a colour sensor, whose
frames a test (or the rig) injects; the driver (`realsense.RealSenseCamera`) reads them through librealsense's
own syncer and aligner, as it reads the camera's. `fail()` makes the device stop as an unplugged one does."""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import pyrealsense2 as rs

from robot.perception.geometry import PinholeIntrinsics

DEPTH_SCALE = 0.001  # the D435i's: 1 mm a count


def _intrinsics(i: PinholeIntrinsics) -> Any:
    out = rs.intrinsics()
    out.width, out.height = i.width, i.height
    out.fx, out.fy, out.ppx, out.ppy = i.fx, i.fy, i.cx, i.cy
    out.model = rs.distortion.none
    out.coeffs = [0.0] * 5
    return out


class SoftwareSource:
    """Depth and colour from the same viewpoint at `intrinsics` (the rig renders both from the head camera)."""

    depth_scale = DEPTH_SCALE

    def __init__(self, intrinsics: PinholeIntrinsics, fps: int = 30) -> None:
        self.intrinsics = intrinsics
        self._device = rs.software_device()
        self._depth_sensor = self._device.add_sensor("Depth")
        self._color_sensor = self._device.add_sensor("Color")
        self._depth_sensor.add_read_only_option(rs.option.depth_units, DEPTH_SCALE)
        self._depth_profile = self._depth_sensor.add_video_stream(
            self._stream(rs.stream.depth, 0, 2, rs.format.z16, fps)
        )
        self._color_profile = self._color_sensor.add_video_stream(
            self._stream(rs.stream.color, 1, 3, rs.format.rgb8, fps)
        )
        identity = rs.extrinsics()
        identity.rotation = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        identity.translation = [0.0, 0.0, 0.0]
        self._depth_profile.register_extrinsics_to(self._color_profile, identity)
        self._device.create_matcher(rs.matchers.default)
        self._syncer = rs.syncer()
        self._lock = threading.Lock()
        self._frame_number = 0
        self._failed = False
        self._started = False
        self._keep: list[np.ndarray] = []  # librealsense reads the pixels after on_video_frame returns

    def _stream(self, kind: Any, uid: int, bpp: int, fmt: Any, fps: int) -> Any:
        stream = rs.video_stream()
        stream.type, stream.index, stream.uid = kind, 0, uid
        stream.width, stream.height, stream.fps, stream.bpp, stream.fmt = (
            self.intrinsics.width,
            self.intrinsics.height,
            fps,
            bpp,
            fmt,
        )
        stream.intrinsics = _intrinsics(self.intrinsics)
        return stream

    def start(self) -> None:
        if self._failed:
            raise RuntimeError("no RealSense device connected")
        if not self._started:
            self._depth_sensor.open(self._depth_profile)
            self._color_sensor.open(self._color_profile)
            self._depth_sensor.start(self._syncer)
            self._color_sensor.start(self._syncer)
            self._started = True

    def inject(self, rgb: np.ndarray, depth_m: np.ndarray) -> None:
        """One colour image (H, W, 3 uint8 RGB) and its depth (m, 0: no return), taken together."""
        with self._lock:
            self._frame_number += 1
            stamp = time.time() * 1000
            counts = np.clip(np.round(depth_m / DEPTH_SCALE), 0, 65535).astype(np.uint16)
            colour = np.ascontiguousarray(rgb, dtype=np.uint8)
            self._keep = [counts, colour]
            width = self.intrinsics.width
            for sensor, profile, pixels, bpp in (
                (self._depth_sensor, self._depth_profile, counts, 2),
                (self._color_sensor, self._color_profile, colour, 3),
            ):
                frame = rs.software_video_frame()
                frame.pixels, frame.stride, frame.bpp = pixels, width * bpp, bpp
                frame.timestamp, frame.domain = stamp, rs.timestamp_domain.hardware_clock
                frame.frame_number, frame.profile = self._frame_number, profile.as_video_stream_profile()
                sensor.on_video_frame(frame)

    def fail(self) -> None:
        """The camera unplugged: reads fail, and it cannot be opened again."""
        self._failed = True

    def frames(self, timeout_ms: int) -> Any:
        if self._failed:
            raise RuntimeError("the RealSense device was disconnected")
        ok, frames = self._syncer.try_wait_for_frames(timeout_ms)
        return frames if ok else None

    def stop(self) -> None:
        if self._started:
            for sensor in (self._depth_sensor, self._color_sensor):
                sensor.stop()
                sensor.close()
            self._started = False
