"""The robot's data as Foxglove messages, for the exported sessions and the live server alike.

Frames: "world" is the simulation's (and the map's) frame; each body of the robot and of the scene is a frame of its
own name (app.foxglove.frames), the robot's are its URDF's links; camera images name the camera's optical frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from foxglove.messages import (
    CompressedImage,
    Grid,
    JointState,
    JointStates,
    LaserScan,
    Log,
    LogLevel,
    PackedElementField,
    PackedElementFieldNumericType,
    Pose,
    Quaternion,
    Timestamp,
    Vector2,
    Vector3,
)

from robot.interface import OccupancyMap, ScanView
from robot.model import humanoid_v1

WORLD_FRAME = "world"
CAMERA_FRAME = humanoid_v1.HEAD_CAMERA  # the optical frame the URDF gives the head camera
MAP_HEIGHT_M = 0.005  # the map's cells float this far above the floor, not through it
_LEVELS = {0: LogLevel.Info, 1: LogLevel.Warning, 2: LogLevel.Error, 3: LogLevel.Warning}


def stamp(t_ns: int) -> Timestamp:
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    return Timestamp(sec, nsec)


def quaternion(wxyz: Sequence[float]) -> Quaternion:
    return Quaternion(x=float(wxyz[1]), y=float(wxyz[2]), z=float(wxyz[3]), w=float(wxyz[0]))


def pose(position: Sequence[float], wxyz: Sequence[float]) -> Pose:
    return Pose(position=vector(position), orientation=quaternion(wxyz))


def vector(values: Sequence[float]) -> Vector3:
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def _yaw(yaw: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def robot_description(urdf: str) -> dict[str, str]:
    """A std_msgs/String carrying the URDF, as the 3D panels' URDF layer reads /robot_description."""
    return {"data": urdf}


def joint_states(
    names: Sequence[str],
    positions: Sequence[float],
    t_ns: int,
    velocities: Sequence[float] | None = None,
    efforts: Sequence[float] | None = None,
) -> JointStates:
    return JointStates(
        timestamp=stamp(t_ns),
        joints=[
            JointState(
                name=name,
                position=finite(positions[i]),
                velocity=None if velocities is None else finite(velocities[i]),
                effort=None if efforts is None else finite(efforts[i]),
            )
            for i, name in enumerate(names)
        ],
    )


def laser_scan(scan: ScanView, t_ns: int) -> LaserScan:
    """The scan in the world frame, from the sensor's estimated pose. Beams that hit nothing are NaN: the panels
    draw no point for them (an infinite range passes their range check and is drawn far away)."""
    ranges = np.asarray(scan.ranges, dtype=float)
    x, y, yaw = scan.pose
    return LaserScan(
        timestamp=stamp(t_ns),
        frame_id=WORLD_FRAME,
        pose=pose((x, y, scan.height_m), _yaw(yaw)),
        start_angle=float(scan.angle_min),
        end_angle=float(scan.angle_min + scan.angle_increment * max(len(ranges) - 1, 0)),
        ranges=np.where(np.isfinite(ranges), ranges, np.nan).tolist(),
    )


def occupancy_colours(cells: np.ndarray) -> np.ndarray:
    """(n, 4) RGBA bytes of occupancy values (0-100, -1 unknown): free cells faint, occupied ones dark, unknown
    ones transparent."""
    p = np.clip(cells.astype(float), 0.0, 100.0) / 100.0
    grey = np.round(235.0 - 205.0 * p).astype(np.uint8)
    alpha = np.where(cells < 0, 0, np.round(70.0 + 180.0 * p)).astype(np.uint8)
    return np.stack([grey, grey, grey, alpha], axis=1)


def occupancy_grid(grid: OccupancyMap, t_ns: int) -> Grid:
    """The map as a foxglove.Grid of RGBA cells (the panels' "RGBA fields" colour mode), its cell (0, 0) corner at
    the map's origin, rows along +y."""
    cells = np.frombuffer(grid.data, dtype=np.int8)
    fields = [
        PackedElementField(name=name, offset=i, type=PackedElementFieldNumericType.Uint8)
        for i, name in enumerate(("red", "green", "blue", "alpha"))
    ]
    return Grid(
        timestamp=stamp(t_ns),
        frame_id=WORLD_FRAME,
        pose=pose((grid.origin[0], grid.origin[1], MAP_HEIGHT_M), (1.0, 0.0, 0.0, 0.0)),
        column_count=int(grid.width),
        cell_size=Vector2(x=float(grid.resolution), y=float(grid.resolution)),
        row_stride=4 * int(grid.width),
        cell_stride=4,
        fields=fields,
        data=occupancy_colours(cells).tobytes(),
    )


def compressed_image(jpeg: bytes, t_ns: int) -> CompressedImage:
    return CompressedImage(timestamp=stamp(t_ns), frame_id=CAMERA_FRAME, data=jpeg, format="jpeg")


def log(t_ns: int, level: int, name: str, message: str) -> Log:
    """A log line; `level` as robot.interface.Level (OK, WARN, ERROR, STALE)."""
    return Log(timestamp=stamp(t_ns), level=_LEVELS.get(int(level), LogLevel.Info), message=message, name=name)
