"""An IMU's reading in the trunk frame, whichever IMU gave it (the OpenCR's, a BNO055), and the conversions
between a quaternion and roll, pitch and yaw."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ImuSample:
    """One IMU reading in the trunk frame: orientation (wxyz), angular velocity (rad/s) and specific force (m/s^2,
    +9.8 up when still); `stamp_s` on the body's clock."""

    quat: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    stamp_s: float
    voltage_v: float = math.nan


def quat_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """wxyz of the rotation yaw about z, then pitch about y, then roll about x (ZYX, radians)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def rpy_from_quat(q: np.ndarray) -> tuple[float, float, float]:
    w, x, y, z = (float(v) for v in q)
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw
