"""A 2D lidar in simulation: one horizontal ring of rays cast with `mujoco.mj_multiRay` (about 0.1 ms per scan).

The ring is levelled: its rays stay horizontal whatever the trunk's tilt (a walking trunk rocks by up to 12 deg,
which would sweep a rigidly mounted plane into the floor 1 m ahead). On the OS1-16 this is choosing, from its 16
beams, the one nearest the horizon using the IMU. Only the world's geometry is hit: the robot's own links are in
other geom groups.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from robot.model import humanoid_v1

BEAMS = 512  # the OS1's lowest horizontal resolution
RANGE_MIN_M = 0.05
RANGE_MAX_M = 8.0
RANGE_NOISE_M = 0.01  # the OS1's precision at short range
WORLD_ONLY = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)


@dataclass(frozen=True)
class LaserScan:
    """As ROS sensor_msgs/LaserScan: beam i points at angle_min + i * angle_increment in the sensor frame (whose
    x axis is the robot's heading); `ranges` holds inf where nothing was hit within range."""

    sim_time_s: float
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray  # (beams,) float32
    height_m: float  # of the scan plane above the floor

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges))

    def points(self, x: float, y: float, yaw: float) -> np.ndarray:
        """(N, 2) world points of the returns, for a sensor at (x, y) with heading `yaw`."""
        hit = np.isfinite(self.ranges)
        angle = self.angles()[hit] + yaw
        r = self.ranges[hit]
        return np.stack([x + r * np.cos(angle), y + r * np.sin(angle)], axis=-1)


class SimLidar:
    def __init__(
        self, model: mujoco.MjModel, beams: int = BEAMS, noise_m: float = RANGE_NOISE_M, seed: int = 0
    ) -> None:
        self._model = model
        self._site = model.site(humanoid_v1.LIDAR_SITE).id
        self._angles = -math.pi + (2.0 * math.pi / beams) * np.arange(beams)
        self._geomid = np.zeros(beams, dtype=np.int32)
        self._dist = np.zeros(beams, dtype=np.float64)
        self._noise = noise_m
        self._rng = np.random.default_rng(seed)

    def scan(self, data: mujoco.MjData) -> LaserScan:
        """One revolution at the pose `data` holds (its kinematics must be current)."""
        origin = data.site_xpos[self._site].copy()
        rotation = data.site_xmat[self._site].reshape(3, 3)
        heading = math.atan2(rotation[1, 0], rotation[0, 0])
        world_angles = self._angles + heading
        directions = np.stack([np.cos(world_angles), np.sin(world_angles), np.zeros_like(world_angles)], axis=-1)
        mujoco.mj_multiRay(
            self._model,
            data,
            origin,
            directions.ravel(),
            WORLD_ONLY,
            1,
            -1,
            self._geomid,
            self._dist,
            None,
            len(self._angles),
            RANGE_MAX_M,
        )
        ranges = self._dist.copy()
        if self._noise > 0:
            ranges += self._rng.standard_normal(len(ranges)) * self._noise
        ranges[(self._geomid < 0) | (self._dist < 0) | (ranges < RANGE_MIN_M) | (ranges > RANGE_MAX_M)] = np.inf
        return LaserScan(
            float(data.time),
            float(self._angles[0]),
            float(self._angles[1] - self._angles[0]),
            RANGE_MIN_M,
            RANGE_MAX_M,
            ranges.astype(np.float32),
            float(origin[2]),
        )
