"""The perception API: camera frames with their detections, the scan, the map, world memory."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import cv2
import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.runtime import Runtime
from app.settings import Settings
from app.web.main import create_app


@pytest.fixture
def seeing_client(settings: Settings, make_worker) -> Iterator[TestClient]:
    """The app on a real-time worker with its perception on (the sensors run in their own process)."""
    worker = make_worker(realtime=True, perception=True)
    runtime = Runtime.start(settings, worker=worker)
    with TestClient(create_app(settings, runtime=runtime)) as test_client:
        assert worker.wait_for(lambda s: s.perception.frame_seq >= 3 and s.perception.map_scans > 0, 60)
        yield test_client
    runtime.stop()


def test_camera_scan_map_and_memory_are_served(seeing_client: TestClient) -> None:
    jpeg = seeing_client.get("/api/camera.jpg")
    assert jpeg.status_code == 200 and jpeg.headers["content-type"] == "image/jpeg"
    assert jpeg.content[:2] == b"\xff\xd8" and int(jpeg.headers["x-frame-seq"]) >= 3

    scan = seeing_client.get("/api/scan").json()
    assert len(scan["ranges"]) == 512 and scan["angle_increment"] > 0
    assert all(r is None or 0.05 <= r <= scan["range_max"] for r in scan["ranges"])

    grid = seeing_client.get("/api/map").json()
    info = grid["info"]
    assert len(grid["data"]) == info["width"] * info["height"] and info["resolution"] == 0.05
    data = np.asarray(grid["data"])
    assert (data == -1).any() and (data >= 67).any() and ((data >= 0) & (data <= 40)).any()
    png = seeing_client.get("/api/map.png")
    assert png.status_code == 200 and png.content[:4] == b"\x89PNG"

    perception = seeing_client.get("/api/perception").json()
    # both sensors deliver (how fast is the perception bench's business: a busy machine gives fewer frames)
    assert perception["status"] == "ok" and perception["camera_hz"] > 0 and perception["lidar_hz"] > 0
    assert "red mug" in {k["name"] for k in perception["known_objects"]}  # in view from where it starts (seed 0)
    assert seeing_client.get("/api/state").json()["perception"]["status"] == "ok"


def _next_frame(ws: Any) -> tuple[dict[str, Any], bytes | None]:
    """A frame's header, and its JPEG unless the header says the page already has the picture."""
    header = ws.receive_json()
    assert header["type"] == "frame" and header["width"] == 640 and header["height"] == 480
    assert all(set(d) >= {"label", "confidence", "position", "box"} for d in header["detections"])
    return header, None if header.get("unchanged") else ws.receive_bytes()


def test_camera_socket_sends_each_frame_after_its_detections(seeing_client: TestClient) -> None:
    with seeing_client.websocket_connect("/ws/camera") as ws:
        header, image = _next_frame(ws)
        assert image is not None  # a page's first frame always carries its picture
        assert image[:2] == b"\xff\xd8"
        # as large as the page draws it (320 px), the boxes still in the camera's 640 x 480 pixels
        assert cv2.imdecode(np.frombuffer(image, np.uint8), cv2.IMREAD_COLOR).shape == (240, 320, 3)
        seqs = [header["seq"]]
        # the robot standing still: the same picture comes again as a header alone, frame after frame
        for _ in range(200):
            header, image = _next_frame(ws)
            seqs.append(header["seq"])
            if image is None:
                break
        assert image is None, "a robot standing still sent a new picture with every frame"
        assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    with seeing_client.websocket_connect("/ws/camera") as ws:  # a page that joins now gets the picture first
        assert _next_frame(ws)[1] is not None
    whole = seeing_client.get("/api/camera.jpg").content
    assert cv2.imdecode(np.frombuffer(whole, np.uint8), cv2.IMREAD_COLOR).shape == (480, 640, 3)


def test_without_perception_the_api_says_why(client: TestClient) -> None:
    response = client.get("/api/camera.jpg")
    assert response.status_code == 503 and "perception: off" in response.json()["detail"]
    assert client.get("/api/map").status_code == 503
    assert client.get("/api/perception").json() == {"status": "off"}
