"""The head camera's frames as pages are sent them: no larger than the page draws them.

The camera takes 640 x 480 JPEGs; the page draws them on a 320 x 240 canvas. Sent whole, they were about 1 Mbit/s
of a viewer's ~1.9 Mbit/s at 10 frames/s (`humanoid bench network`), with nothing to see for it. Each frame is
scaled once for every page (libjpeg decodes it at half size directly), on a worker thread: never on the event
loop, never once per page. Detections stay in the camera's own pixels (the frame header's width and height).
"""

from __future__ import annotations

import asyncio

import cv2
import numpy as np

from robot.interface import CameraImage

JPEG_QUALITY = 80
_REDUCED = ((8, cv2.IMREAD_REDUCED_COLOR_8), (4, cv2.IMREAD_REDUCED_COLOR_4), (2, cv2.IMREAD_REDUCED_COLOR_2))


def scale_jpeg(jpeg: bytes, image_width: int, width: int) -> bytes:
    """`jpeg` (`image_width` pixels across) scaled to `width` pixels across, height in proportion; as it is when
    it is not wider, when `width` is 0, or when it cannot be decoded."""
    if width <= 0 or image_width <= width or not jpeg:
        return jpeg
    flag = next((f for factor, f in _REDUCED if image_width // factor >= width), cv2.IMREAD_COLOR)
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), flag)
    if image is None:
        return jpeg
    if image.shape[1] > width:  # (decoded at a power-of-two fraction: to the exact width)
        height = max(1, round(image.shape[0] * width / image.shape[1]))
        image = cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    return encoded.tobytes() if ok else jpeg


class PageFrames:
    """The latest frame scaled for pages, made once however many pages wait for it."""

    def __init__(self, width: int) -> None:
        self._width = width
        self._frame: CameraImage | None = None
        self._scaled: asyncio.Future[bytes] | None = None

    async def jpeg(self, frame: CameraImage) -> bytes:
        if frame is not self._frame or self._scaled is None:
            self._frame = frame
            self._scaled = asyncio.ensure_future(asyncio.to_thread(scale_jpeg, frame.jpeg, frame.width, self._width))
        return await asyncio.shield(self._scaled)
