"""Scan matching: corrects the leg odometry's slow drift by fitting each lidar scan to the scans seen before.

As ROS keeps a map -> odom transform, the correction is a 2D transform applied to odometry poses: the map is built,
and objects are placed, at corrected poses. Past scans' end points are counted on a fine grid (1 cm); a likelihood
field is rebuilt from the counts once a second, and each new scan searches small shifts around the current correction
(coarse, then fine) for the position where its end points lie best on that field. Matching against the 5 cm occupancy
cells instead biased every match towards cell centres (up to 2.5 cm) and the correction walked away with it.

The field peaks where past end points are densest, across each surface: the counts blurred by a Gaussian, over their
local maximum. The lidar's 1 cm range noise spreads a wall's returns over a band 4-6 cm wide; a field that was flat
across the whole band (the distance to the nearest cell hit three times) let the correction slide within it, 1 cm
off on average and up to 3-4 cm, which put walls a map cell off (the map's IoU fell to 0.85 on one tour in ten).

The heading is left to the IMU: its yaw does not drift in simulation, and a matcher free to turn was measured to
add a 3 deg error over a tour. The correction moves only when a match is clearly better than the current one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from robot.perception.lidar import LaserScan
from robot.perception.occupancy import GridSpec

FIELD_RESOLUTION_M = 0.01
SIGMA_M = 0.015  # the blur of the end point counts
# Where the blurred counts are below this (about three returns in one fine cell), there is no surface.
MIN_DENSITY = 3.0 / (2.0 * math.pi * (SIGMA_M / FIELD_RESOLUTION_M) ** 2)
PEAK_WINDOW_M = 0.02  # each side: surfaces nearer each other than this share a peak
MAX_COUNT = 30000  # end point counts per fine cell (uint16)
FIELD_EVERY = 10  # scans between rebuilds of the likelihood field
MIN_POINTS = 60
COARSE = (0.02, 4)  # step (m), steps each side
FINE = (0.0025, 4)
# A scan is matched only where its end points already lie this well on the field (a share of a perfect score).
MIN_OVERLAP = 0.3
BETTER_BY = 1.005  # the best candidate must beat the current correction by 0.5 %
GAIN = 1.0  # share of the way to the best candidate taken per scan


@dataclass(frozen=True)
class Correction:
    """map pose = rotate(yaw) * odom position + (x, y); map heading = odom heading + yaw."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def apply(self, x: float, y: float, heading: float) -> tuple[float, float, float]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (c * x - s * y + self.x, s * x + c * y + self.y, heading + self.yaw)

    def matrix(self) -> np.ndarray:
        """As a 4x4 transform (a turn about z and a shift), for 3D poses such as the camera's."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        out = np.eye(4)
        out[:2, :2] = [[c, -s], [s, c]]
        out[:2, 3] = (self.x, self.y)
        return out


class ScanMatcher:
    def __init__(self, spec: GridSpec) -> None:
        scale = round(spec.resolution / FIELD_RESOLUTION_M)
        self._spec = GridSpec(spec.x0, spec.y0, spec.nx * scale, spec.ny * scale, FIELD_RESOLUTION_M)
        self._hits = np.zeros((self._spec.nx, self._spec.ny), dtype=np.uint16)
        self._field: np.ndarray | None = None
        self._since_field = 0
        self.correction = Correction()
        self.matched = 0

    def update(self, scan: LaserScan, odom_pose: tuple[float, float, float]) -> Correction:
        """Refine the correction with this scan (taken at `odom_pose`, the sensor's pose by odometry), then add
        the scan, at the corrected pose, to what later scans are matched against."""
        hit = np.isfinite(scan.ranges)
        angles = scan.angles()[hit]
        ranges = scan.ranges[hit].astype(float)
        local = np.stack([ranges * np.cos(angles), ranges * np.sin(angles)], axis=-1)
        if self._field is not None and len(local) >= MIN_POINTS:
            self._match(local, odom_pose)
        self._remember(local, self.correction.apply(*odom_pose))
        return self.correction

    def _match(self, local: np.ndarray, odom_pose: tuple[float, float, float]) -> None:
        assert self._field is not None
        x, y, heading = self.correction.apply(*odom_pose)
        c, s = math.cos(heading), math.sin(heading)
        world = np.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]], axis=-1)
        current = float(self._score(world, np.array([[x, y]]))[0])
        if current < MIN_OVERLAP * len(world):
            return  # mostly surfaces not seen before (a new room): nothing to match them against yet
        best_xy, best = np.array([x, y]), current
        for step, n in (COARSE, FINE):
            offsets = step * np.arange(-n, n + 1)
            dx, dy = np.meshgrid(offsets, offsets, indexing="ij")
            candidates = best_xy + np.stack([dx.ravel(), dy.ravel()], axis=-1)
            scores = self._score(world, candidates)
            k = int(np.argmax(scores))
            if scores[k] > best:
                best_xy, best = candidates[k], float(scores[k])
        if best > current * BETTER_BY:
            old = self.correction
            self.correction = Correction(
                float(old.x + GAIN * (best_xy[0] - x)), float(old.y + GAIN * (best_xy[1] - y)), old.yaw
            )
            self.matched += 1

    def _score(self, world: np.ndarray, origins: np.ndarray) -> np.ndarray:
        """Sum over the end points of the likelihood field (bilinear), for each sensor position in `origins`."""
        field, spec = self._field, self._spec
        assert field is not None
        u = (origins[:, 0:1] + world[:, 0] - spec.x0) / spec.resolution - 0.5
        v = (origins[:, 1:2] + world[:, 1] - spec.y0) / spec.resolution - 0.5
        i0, j0 = np.floor(u), np.floor(v)
        fu, fv = u - i0, v - j0
        inside = (i0 >= 0) & (j0 >= 0) & (i0 < spec.nx - 1) & (j0 < spec.ny - 1)
        # the four corners by flat index from one array of them: indexing the 2D field with (i, j) pairs cost twice
        # as much, and this ran 81 candidates x every end point twice a scan (~12 % of a core at 10 scans/s)
        corner = np.where(inside, i0 * spec.ny + j0, 0.0).astype(np.intp)
        flat = field.reshape(-1)
        value = (
            flat.take(corner) * (1 - fu) * (1 - fv)
            + flat.take(corner + spec.ny) * fu * (1 - fv)
            + flat.take(corner + 1) * (1 - fu) * fv
            + flat.take(corner + (spec.ny + 1)) * fu * fv
        )
        return np.sum(np.where(inside, value, 0.0), axis=1)

    def _remember(self, local: np.ndarray, pose: tuple[float, float, float]) -> None:
        x, y, heading = pose
        c, s = math.cos(heading), math.sin(heading)
        px = x + c * local[:, 0] - s * local[:, 1]
        py = y + s * local[:, 0] + c * local[:, 1]
        i, j = self._spec.cell(px, py)
        inside = (i >= 0) & (i < self._spec.nx) & (j >= 0) & (j < self._spec.ny)
        np.add.at(self._hits, (i[inside], j[inside]), 1)
        if self._hits.max() > MAX_COUNT:  # halve them all: the field's shape stays, and nothing saturates
            self._hits //= 2
        self._since_field += 1
        if self._field is None or self._since_field >= FIELD_EVERY:
            field = likelihood_field(self._hits)
            if field is not None:
                self._field = field
            self._since_field = 0

    def reset(self) -> None:
        self.correction = Correction()
        self._hits[:] = 0
        self._field = None
        self._since_field = 0


def likelihood_field(hits: np.ndarray) -> np.ndarray | None:
    """From end point counts on the fine grid: 1 along the middle of each surface's band of returns, falling off
    across it; 0 away from surfaces. None while too little has been seen."""
    blur = SIGMA_M / FIELD_RESOLUTION_M
    density = cv2.GaussianBlur(hits.astype(np.float32), (0, 0), blur)
    surface = density >= MIN_DENSITY
    if surface.sum() < MIN_POINTS:
        return None
    window = 2 * round(PEAK_WINDOW_M / FIELD_RESOLUTION_M) + 1
    peak = cv2.dilate(density, np.ones((window, window), np.uint8))
    field = np.where(peak >= MIN_DENSITY, density / np.maximum(peak, 1e-6), 0.0)
    return field.astype(np.float64)
