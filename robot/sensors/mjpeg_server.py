"""A camera on the network as many are: an MJPEG stream over HTTP (multipart/x-mixed-replace, one JPEG a part),
which OpenCV opens by URL. For tests of the camera driver without a camera (and the rig's head camera): it serves
the images it is given, at a fixed rate; faults: `stall` (the connection stays open, no frames come) and
`disconnect` (the server goes away)."""

from __future__ import annotations

import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import cv2
import numpy as np

BOUNDARY = "frame"


class MjpegServer:
    def __init__(self, image: np.ndarray, fps: float = 20.0, host: str = "127.0.0.1") -> None:
        self.fps = fps
        self.stall = False
        self.frames_sent = 0
        self._jpeg = b""
        self._lock = threading.Lock()
        self.set_image(image)
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # the standard library names it
                self.send_response(200)
                self.send_header("Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY}")
                self.end_headers()
                server.stream(self)

            def log_message(self, *args: object) -> None:
                """Quiet: tests read their own output."""

        self._http = ThreadingHTTPServer((host, 0), Handler)
        self._http.daemon_threads = True
        self._stop = threading.Event()
        self.url = f"http://{host}:{self._http.server_address[1]}/stream.mjpg"
        self._thread = threading.Thread(target=self._http.serve_forever, name="mjpeg-server", daemon=True)

    def __enter__(self) -> MjpegServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.disconnect()

    def set_image(self, rgb: np.ndarray) -> None:
        ok, jpeg = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 95])
        assert ok
        with self._lock:
            self._jpeg = jpeg.tobytes()

    def disconnect(self) -> None:
        """The camera gone: open streams end and new connections are refused."""
        self._stop.set()
        self._http.shutdown()
        self._http.server_close()

    def stream(self, handler: BaseHTTPRequestHandler) -> None:
        period = 1.0 / self.fps
        try:
            while not self._stop.is_set():
                if not self.stall:
                    with self._lock:
                        jpeg = self._jpeg
                    handler.wfile.write(
                        f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(jpeg)}\r\n\r\n".encode()
                        + jpeg
                        + b"\r\n"
                    )
                    handler.wfile.flush()
                    self.frames_sent += 1
                time.sleep(period)
        except (BrokenPipeError, ConnectionResetError):
            return
