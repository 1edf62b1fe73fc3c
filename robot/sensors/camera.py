"""The head camera on the real robot: any UVC camera (or a video file, or a stream URL) through OpenCV's
`cv2.VideoCapture`. A thread grabs frames as they come and keeps the newest; the perception takes it. A UVC
camera gives colour only: 3D localisation of what it sees needs depth (the RealSense, `realsense.py`).

What goes wrong is said (`problem`): a source that cannot be opened, a camera that stalls (no new frame for
`stall_after_s`), one that is unplugged; the source is reopened every second meanwhile.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from robot.perception.geometry import PinholeIntrinsics
from robot.sensors.reader_thread import ReaderThread

STALL_AFTER_S = 1.0
FAILED_READS_BEFORE_REOPEN = 10
DEFAULT_FOVY_DEG = 45.0
OPEN_TIMEOUT_MS = 5000
READ_TIMEOUT_MS = 3000


@dataclass(frozen=True)
class CameraImage:
    """One frame: colour (H, W, 3) RGB, depth in m aligned to it (0: no return; None for a colour camera), the
    colour image's intrinsics, when it was taken (the body's clock) and its number."""

    rgb: np.ndarray
    depth: np.ndarray | None
    intrinsics: PinholeIntrinsics
    stamp_s: float
    seq: int


def capture_source(text: str) -> int | str:
    """A device index ("0") as an int, anything else (a path, a URL) as it is."""
    return int(text) if text.isdigit() else text


class FrameGrabber(ReaderThread[CameraImage, None]):
    """The newest frame of a source read on its own thread, and what went wrong. A subclass says how to open the
    source and read one frame (`_open`, `_read`, `_close`); a read that fails ten times in a row reopens it."""

    name = "camera"
    thread_name = "camera"

    def __init__(self, clock: Callable[[], float] = time.monotonic, stall_after_s: float = STALL_AFTER_S) -> None:
        super().__init__()
        self.clock = clock
        self.silent_after_s = stall_after_s
        self.frames = 0

    def _silence(self, silent_s: float) -> str:
        return f"stalled: no new frame for {silent_s:.1f} s"

    def _serve(self, source: None) -> None:
        failures = 0
        while not self.stopping and failures < FAILED_READS_BEFORE_REOPEN:
            try:
                frame = self._read()
            except Exception as exc:  # a vendor SDK's own errors, too
                self._say(f"read failed: {exc}")
                frame = None
            if frame is None:
                failures += 1
                continue
            failures = 0
            rgb, depth, intrinsics = frame
            self.frames += 1
            self._publish(CameraImage(rgb, depth, intrinsics, self.clock(), self.frames))
        if not self.stopping:
            self._say("the source stopped giving frames: reopening")

    def _read(self) -> tuple[np.ndarray, np.ndarray | None, PinholeIntrinsics] | None:
        raise NotImplementedError


class UvcCamera(FrameGrabber):
    """`source`: a device index, a path or a stream URL (e.g. an MJPEG stream over HTTP); `fovy_deg`: the lens's
    vertical field of view, for the intrinsics (calibrate it for 3D work)."""

    def __init__(
        self,
        source: str,
        clock: Callable[[], float] = time.monotonic,
        fovy_deg: float = DEFAULT_FOVY_DEG,
        stall_after_s: float = STALL_AFTER_S,
    ) -> None:
        super().__init__(clock, stall_after_s)
        self.source = source
        self.name = f"camera {source}"
        self.fovy_deg = fovy_deg
        self._capture: cv2.VideoCapture | None = None

    def _open(self) -> None:
        source = capture_source(self.source)
        if isinstance(source, str):  # a path or URL: through FFmpeg, which gives up on a dead stream in time
            timeouts = [
                cv2.CAP_PROP_OPEN_TIMEOUT_MSEC,
                OPEN_TIMEOUT_MS,
                cv2.CAP_PROP_READ_TIMEOUT_MSEC,
                READ_TIMEOUT_MS,
            ]
            capture = cv2.VideoCapture(source, cv2.CAP_FFMPEG, timeouts)
        else:
            capture = cv2.VideoCapture(source)
        if not capture.isOpened():
            capture.release()
            raise RuntimeError(f"OpenCV cannot open {self.source}")
        capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # the newest frame, not a queue of old ones
        self._capture = capture

    def _read(self) -> tuple[np.ndarray, None, PinholeIntrinsics] | None:
        assert self._capture is not None
        ok, bgr = self._capture.read()
        if not ok or bgr is None:
            time.sleep(0.01)
            return None
        height, width = bgr.shape[:2]
        intrinsics = PinholeIntrinsics.from_vertical_fov(width, height, self.fovy_deg)
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), None, intrinsics

    def _close(self, source: None) -> None:
        if self._capture is not None:
            self._capture.release()
            self._capture = None
