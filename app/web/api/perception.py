"""What the robot perceives: camera frames (with detections), the lidar scan, the occupancy map, world memory.

`/ws/camera` streams frames to the page: for each new frame a JSON message {"type": "frame", seq, sim_time_s,
width, height, detections, camera_hz} followed by one binary message, the JPEG. A frame whose picture is the one
this page was last sent (a robot standing still: the sensors send the last frame again) comes as its header alone,
with "unchanged": true: no JPEG to send, decode or draw. The detections belong to exactly the frame they precede, so
overlays never lag the image; their boxes are in the camera's pixels (width x height),
while the JPEG is scaled to the page's width (`camera_stream_width`, see `app.web.camera_stream`). `/api/camera.jpg`
is the camera's whole image.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
from typing import Annotated, Any

import cv2
import numpy as np
from fastapi import APIRouter, Depends, HTTPException, Response, WebSocket, WebSocketDisconnect

from app.runtime import Runtime
from app.web.api.deps import runtime
from app.web.camera_stream import PageFrames
from robot.interface import CameraImage, OccupancyMap, PerceptionState, ScanView

router = APIRouter(tags=["perception"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]
CAMERA_POLL_S = 0.02


def perception_json(state: PerceptionState | None) -> dict[str, Any]:
    if state is None:
        return {"status": "off"}
    return dataclasses.asdict(state)


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def scan_json(scan: ScanView) -> dict[str, Any]:
    """As sensor_msgs/LaserScan (ranges with no return are null), plus the pose it was mapped from."""
    angle_max = scan.angle_min + scan.angle_increment * (len(scan.ranges) - 1)
    return {
        "sim_time_s": scan.sim_time_s,
        "pose": {"x": scan.pose[0], "y": scan.pose[1], "yaw_rad": scan.pose[2]},
        "height_m": scan.height_m,
        "angle_min": scan.angle_min,
        "angle_max": angle_max,
        "angle_increment": scan.angle_increment,
        "range_max": scan.range_max,
        "ranges": [_finite(r) for r in scan.ranges],
    }


def map_json(grid: OccupancyMap) -> dict[str, Any]:
    """As nav_msgs/OccupancyGrid: data[j * width + i], 0-100, -1 unknown."""
    return {
        "sim_time_s": grid.sim_time_s,
        "scans": grid.scans,
        "info": {
            "resolution": grid.resolution,
            "width": grid.width,
            "height": grid.height,
            "origin": {"x": grid.origin[0], "y": grid.origin[1]},
        },
        "data": np.frombuffer(grid.data, dtype=np.int8).tolist(),
    }


def map_png(grid: OccupancyMap) -> bytes:
    """The map as an image, +y up: unknown grey, free white, occupied black (shades in between)."""
    data = np.frombuffer(grid.data, dtype=np.int8).reshape(grid.height, grid.width).astype(np.int16)
    image = np.where(data < 0, 160, 255 - (data * 255) // 100).astype(np.uint8)
    ok, png = cv2.imencode(".png", np.flipud(image))
    if not ok:  # pragma: no cover
        raise HTTPException(500, "could not encode the map")
    return png.tobytes()


@router.get("/api/perception")
def perception(rt: RuntimeDep) -> dict[str, Any]:
    """Perception's status: the sensors' rates, the latest detections and the world memory (where each object
    was last seen); `{"status": "off"}` without perception."""
    return perception_json(rt.worker.state().perception)


def _camera(rt: Runtime) -> CameraImage:
    state = rt.worker.state().perception
    frame = rt.worker.sensor_feed().camera
    if frame is None:
        status = state.status if state is not None else "off"
        raise HTTPException(503, f"no camera frame yet (perception: {status})")
    return frame


@router.get("/api/camera.jpg", response_class=Response, responses={200: {"content": {"image/jpeg": {}}}})
def camera_jpeg(rt: RuntimeDep) -> Response:
    """The latest head-camera image."""
    frame = _camera(rt)
    headers = {"X-Frame-Seq": str(frame.seq), "X-Sim-Time": f"{frame.sim_time_s:.3f}", "Cache-Control": "no-store"}
    return Response(frame.jpeg, media_type="image/jpeg", headers=headers)


@router.get("/api/scan")
def scan(rt: RuntimeDep) -> dict[str, Any]:
    """The latest lidar scan, as sensor_msgs/LaserScan (no return: null), with the pose it was mapped from;
    503 before the first."""
    latest = rt.worker.sensor_feed().scan
    if latest is None:
        raise HTTPException(503, "no lidar scan yet")
    return scan_json(latest)


@router.get("/api/map")
def occupancy_map(rt: RuntimeDep) -> dict[str, Any]:
    """The occupancy map, as nav_msgs/OccupancyGrid; 503 before the first scan."""
    grid = rt.worker.sensor_feed().map
    if grid is None:
        raise HTTPException(503, "no occupancy map yet")
    return map_json(grid)


@router.get("/api/map.png", response_class=Response, responses={200: {"content": {"image/png": {}}}})
def occupancy_map_png(rt: RuntimeDep) -> Response:
    """The occupancy map as an image; its origin, resolution and scan count in `X-Map-*` headers."""
    grid = rt.worker.sensor_feed().map
    if grid is None:
        raise HTTPException(503, "no occupancy map yet")
    headers = {
        "Cache-Control": "no-store",
        "X-Map-Origin": f"{grid.origin[0]:.4f},{grid.origin[1]:.4f}",
        "X-Map-Resolution": f"{grid.resolution:.4f}",
        "X-Map-Scans": str(grid.scans),
    }
    return Response(map_png(grid), media_type="image/png", headers=headers)


def _frame_header(app_state: Any, rt: Runtime, frame: CameraImage, unchanged: bool = False) -> str:
    """The frame's JSON header, encoded once for every page watching (kept on the app with its frame); `unchanged`:
    the page already has its picture."""
    cached = getattr(app_state, "camera_header", None)
    if cached is None or cached[0] is not frame:
        state = rt.worker.state().perception
        header = {
            "type": "frame",
            "seq": frame.seq,
            "sim_time_s": frame.sim_time_s,
            "width": frame.width,
            "height": frame.height,
            "camera_hz": state.camera_hz if state else 0.0,
            "detections": [dataclasses.asdict(d) for d in frame.detections],
        }
        cached = (frame, json.dumps(header), json.dumps({**header, "unchanged": True}))
        app_state.camera_header = cached
    return cached[2] if unchanged else cached[1]


def _page_frames(app_state: Any, rt: Runtime) -> PageFrames:
    """The frames as pages are sent them (one for every page, kept on the app)."""
    frames = getattr(app_state, "camera_page_frames", None)
    if frames is None:
        frames = app_state.camera_page_frames = PageFrames(rt.settings.camera_stream_width)
    return frames


@router.websocket("/ws/camera")
async def camera_socket(ws: WebSocket) -> None:
    rt: Runtime = ws.app.state.runtime
    await ws.accept()
    frames = _page_frames(ws.app.state, rt)
    last_seq, last_picture = -1, b""
    try:
        while True:
            frame = rt.worker.sensor_feed().camera
            if frame is not None and frame.seq != last_seq:
                last_seq = frame.seq
                if frame.jpeg == last_picture:
                    await ws.send_text(_frame_header(ws.app.state, rt, frame, unchanged=True))
                else:
                    last_picture = frame.jpeg
                    jpeg = await frames.jpeg(frame)
                    await ws.send_text(_frame_header(ws.app.state, rt, frame))
                    await ws.send_bytes(jpeg)
            await asyncio.sleep(CAMERA_POLL_S)
    except (WebSocketDisconnect, RuntimeError):
        pass
