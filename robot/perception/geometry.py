"""Rigid transforms and the pinhole camera model shared by the perception modules (plain numpy, 4x4 matrices)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# MuJoCo cameras look along their -z with y up; the optical frame (OpenCV, ROS *_optical_frame) looks along +z
# with y down. optical = mujoco @ this.
MUJOCO_TO_OPTICAL = np.diag([1.0, -1.0, -1.0])


def transform(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """4x4 homogeneous transform from a 3x3 rotation and a translation."""
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = translation
    return out


def invert(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def quat_wxyz_to_matrix(q: np.ndarray | tuple[float, ...]) -> np.ndarray:
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z) or 1.0
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat_wxyz(r: np.ndarray) -> tuple[float, float, float, float]:
    """Rotation matrix to a unit quaternion (w >= 0)."""
    trace = float(r[0, 0] + r[1, 1] + r[2, 2])
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s)
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = ((r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s)
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = ((r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = ((r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s)
    w, x, y, z = (float(v) for v in q)
    return (w, x, y, z) if w >= 0 else (-w, -x, -y, -z)


def yaw_of(rotation: np.ndarray) -> float:
    return math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))


@dataclass(frozen=True)
class PinholeIntrinsics:
    """Pixel (u, v) of a point (x, y, z) in the optical frame: u = fx x / z + cx, v = fy y / z + cy.

    Pixel indices name pixel centres, so the image centre of a W-wide image is at u = (W - 1) / 2.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @staticmethod
    def from_vertical_fov(width: int, height: int, fovy_deg: float) -> PinholeIntrinsics:
        f = (height / 2.0) / math.tan(math.radians(fovy_deg) / 2.0)
        return PinholeIntrinsics(width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0)

    @property
    def hfov_deg(self) -> float:
        return 2.0 * math.degrees(math.atan((self.width / 2.0) / self.fx))

    def back_project(self, u: np.ndarray, v: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """(N, 3) points in the optical frame from pixel coordinates and z-depth (m)."""
        x = (u - self.cx) * depth / self.fx
        y = (v - self.cy) * depth / self.fy
        return np.stack([x, y, depth], axis=-1)

    def project(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) pixel coordinates of (N, 3) optical-frame points (z > 0)."""
        z = points[:, 2]
        return np.stack([self.fx * points[:, 0] / z + self.cx, self.fy * points[:, 1] / z + self.cy], axis=-1)
