"""A RealSense fed by the hardware-in-the-loop rig: librealsense can only be given frames that do not come from a
camera through its own `software_device`, which lives in the process reading it. So the rig streams its head
camera's RGB-D frames over a Unix socket (`rgbd_stream`) and this source injects them into a software device here;
`RealSenseCamera` then syncs, aligns and reads them exactly as it reads the camera's (config: `camera = "rig:PATH"`).
"""

from __future__ import annotations

import contextlib
import socket
import threading
from typing import Any

from robot.sensors.realsense_emulator import DEPTH_SCALE, SoftwareSource
from robot.sensors.rgbd_stream import read_frame

CONNECT_TIMEOUT_S = 10.0


class RigFrameSource:
    depth_scale = DEPTH_SCALE

    def __init__(self, path: str) -> None:
        self.path = path
        self._socket: socket.socket | None = None
        self._software: SoftwareSource | None = None
        self._thread: threading.Thread | None = None
        self._ended = threading.Event()

    def start(self) -> None:
        """Connect and take the first frame (its size and intrinsics make the software device)."""
        if self._software is not None:
            return
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.settimeout(CONNECT_TIMEOUT_S)
        try:
            sock.connect(self.path)
            stream = sock.makefile("rb")
            first = read_frame(stream)
        except OSError as exc:
            sock.close()
            raise RuntimeError(f"no camera stream at {self.path}: {exc}") from exc
        if first is None:
            sock.close()
            raise RuntimeError(f"the camera stream at {self.path} ended before its first frame")
        sock.settimeout(None)
        self._socket = sock
        self._software = SoftwareSource(first.intrinsics)
        self._software.start()
        self._software.inject(first.rgb, first.depth_m)
        self._ended.clear()
        self._thread = threading.Thread(target=self._pump, args=(stream,), name="rig-camera-feed", daemon=True)
        self._thread.start()

    def _pump(self, stream: Any) -> None:
        try:
            while (frame := read_frame(stream)) is not None:
                assert self._software is not None
                self._software.inject(frame.rgb, frame.depth_m)
        except (OSError, ValueError):
            pass
        self._ended.set()

    def frames(self, timeout_ms: int) -> Any:
        if self._ended.is_set() or self._software is None:
            raise RuntimeError(f"the camera stream at {self.path} ended")
        return self._software.frames(timeout_ms)

    def stop(self) -> None:
        if self._socket is not None:
            with contextlib.suppress(OSError):
                self._socket.shutdown(socket.SHUT_RDWR)
            self._socket.close()
            self._socket = None
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        if self._software is not None:
            self._software.stop()
            self._software = None
