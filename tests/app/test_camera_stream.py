"""Camera frames for pages: scaled to the width the page draws, proportions kept; left alone when they are not
wider, when scaling is off, or when they are not JPEGs."""

from __future__ import annotations

import asyncio

import cv2
import numpy as np

from app.web.camera_stream import PageFrames, scale_jpeg
from robot.interface import CameraImage


def jpeg(width: int, height: int) -> bytes:
    rng = np.random.default_rng(0)
    image = np.zeros((height, width, 3), np.uint8)
    image[: height // 2] = (40, 120, 200)
    image[height // 2 :] = rng.integers(0, 255, (height - height // 2, width, 3), dtype=np.uint8)
    return cv2.imencode(".jpg", image)[1].tobytes()


def shape(data: bytes) -> tuple[int, ...]:
    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR).shape


def test_a_wide_frame_is_scaled_to_the_width_with_its_proportions() -> None:
    original = jpeg(640, 480)
    scaled = scale_jpeg(original, 640, 320)
    assert shape(scaled) == (240, 320, 3)
    assert len(scaled) < len(original) / 2
    assert shape(scale_jpeg(original, 640, 200)) == (150, 200, 3)  # (not a power of two: decoded small, resized)
    assert shape(scale_jpeg(jpeg(1280, 720), 1280, 320)) == (180, 320, 3)


def test_frames_not_wider_scaling_off_or_not_jpeg_are_sent_as_they_are() -> None:
    small = jpeg(320, 240)
    assert scale_jpeg(small, 320, 320) is small
    big = jpeg(640, 480)
    assert scale_jpeg(big, 640, 0) is big
    assert scale_jpeg(b"not a jpeg", 640, 320) == b"not a jpeg"


def test_pages_waiting_for_the_same_frame_share_one_scaling() -> None:
    frames = PageFrames(320)
    frame = CameraImage(seq=1, sim_time_s=0.0, width=640, height=480, jpeg=jpeg(640, 480), detections=())

    async def three_pages() -> list[bytes]:
        return await asyncio.gather(*(frames.jpeg(frame) for _ in range(3)))

    first, second, third = asyncio.run(three_pages())
    assert first is second is third and shape(first) == (240, 320, 3)
