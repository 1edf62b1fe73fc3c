"""The Intel RealSense D435i head camera through `pyrealsense2` (the optional `realsense` extra; it needs Debian's
libusb-1.0-0): colour and depth, the depth aligned to the colour image, in metres, with the colour stream's own
intrinsics, so detection and 3D localisation run on its frames as on the simulated camera's.

The frames come from a `FrameSource`: the camera through a `rs.pipeline` (`PipelineSource`), or, for tests and
the rig, frames injected through librealsense's own `software_device` (`realsense_emulator.SoftwareSource`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
import pyrealsense2 as rs

from robot.perception.geometry import PinholeIntrinsics
from robot.sensors.camera import STALL_AFTER_S, FrameGrabber

WAIT_MS = 500


class FrameSource(Protocol):
    depth_scale: float  # metres per depth count

    def start(self) -> None: ...

    def frames(self, timeout_ms: int) -> Any:
        """The next frameset (`rs.composite_frame`), or None if none came in time."""

    def stop(self) -> None: ...


class PipelineSource:
    """A D435i on USB: colour RGB and depth at the same size and rate."""

    def __init__(self, width: int = 640, height: int = 480, fps: int = 30, serial: str = "") -> None:
        self.config = rs.config()
        if serial:
            self.config.enable_device(serial)
        self.config.enable_stream(rs.stream.color, width, height, rs.format.rgb8, fps)
        self.config.enable_stream(rs.stream.depth, width, height, rs.format.z16, fps)
        self.pipeline = rs.pipeline()
        self.depth_scale = 0.001

    def start(self) -> None:
        profile = self.pipeline.start(self.config)
        self.depth_scale = profile.get_device().first_depth_sensor().get_depth_scale()

    def frames(self, timeout_ms: int) -> Any:
        ok, frames = self.pipeline.try_wait_for_frames(timeout_ms)
        return frames if ok else None

    def stop(self) -> None:
        self.pipeline.stop()


def intrinsics_of(profile: Any) -> PinholeIntrinsics:
    i = profile.as_video_stream_profile().get_intrinsics()
    return PinholeIntrinsics(i.width, i.height, i.fx, i.fy, i.ppx, i.ppy)


class RealSenseCamera(FrameGrabber):
    def __init__(
        self,
        source: FrameSource | None = None,
        clock: Callable[[], float] = time.monotonic,
        stall_after_s: float = STALL_AFTER_S,
    ) -> None:
        super().__init__(clock, stall_after_s)
        self.name = "RealSense D435i"
        self.source = source or PipelineSource()
        self._align = rs.align(rs.stream.color)
        self._started = False

    def _open(self) -> None:
        self.source.start()
        self._started = True

    def _read(self) -> tuple[np.ndarray, np.ndarray, PinholeIntrinsics] | None:
        frames = self.source.frames(WAIT_MS)
        if frames is None or frames.size() < 2:
            return None  # nothing yet, or colour without its depth (the sync's first frame)
        aligned = self._align.process(frames)
        color, depth = aligned.get_color_frame(), aligned.get_depth_frame()
        if not color or not depth:
            return None
        rgb = np.asanyarray(color.get_data()).copy()
        metres = np.asanyarray(depth.get_data()).astype(np.float32) * self.source.depth_scale
        return rgb, metres, intrinsics_of(color.profile)

    def _close(self, source: None) -> None:
        if self._started:
            self.source.stop()
            self._started = False
