"""What a body's sensors say each tick, in one immutable record the controllers read."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# A biped is considered fallen beyond this trunk tilt or below this trunk height.
FALL_TILT_DEG = 45.0
FALL_HEIGHT_M = 0.12  # a deep crouch (reaching to a 0.2 m table) brings the trunk to 0.15 m


@dataclass(frozen=True)
class Measurements:
    """What the controller reads each tick."""

    sim_time_s: float
    joint_positions: np.ndarray  # (n_joints,) in the body's joint order
    joint_velocities: np.ndarray
    base_position: np.ndarray  # (3,)
    base_quat: np.ndarray  # (4,) wxyz
    imu_quat: np.ndarray  # (4,) wxyz, trunk orientation from the IMU
    imu_gyro: np.ndarray  # (3,) rad/s in the trunk frame
    imu_accel: np.ndarray  # (3,) m/s^2 in the trunk frame (specific force: +9.8 up when still)
    foot_forces: np.ndarray  # (2, 4) N on each sole's four force pads, left then right
    joint_torques: np.ndarray | None = None  # (n_joints,) Nm the servos exert (what their current says)
    com: np.ndarray | None = None  # (3,) the robot's centre of mass in the world frame
    imu_stamp_s: float | None = None  # when the IMU sample was taken (None: this tick)

    @property
    def tilt_deg(self) -> float:
        _, x, y, _ = self.base_quat
        # z component of the trunk's up axis in the world frame
        up_z = 1.0 - 2.0 * (x * x + y * y)
        return math.degrees(math.acos(max(-1.0, min(1.0, up_z))))

    @property
    def yaw_rad(self) -> float:
        w, x, y, z = self.base_quat
        return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    @property
    def fallen(self) -> bool:
        return bool(self.tilt_deg > FALL_TILT_DEG or self.base_position[2] < FALL_HEIGHT_M)
