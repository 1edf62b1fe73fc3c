"""An occupancy grid built from lidar scans at the robot's estimated pose (log-odds, as ROS's gmapping/costmaps).

Each scan marks the cells its beams cross as more likely free and the cells they end in as more likely occupied.
Exported like ROS nav_msgs/OccupancyGrid: 0-100 occupancy, -1 unknown. Navigation plans on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robot.perception.lidar import LaserScan

RESOLUTION_M = 0.05
# Log-odds added per observation; clamped so a moved obstacle is forgotten after a few scans.
HIT = 0.85
MISS = -0.4
CLAMP = (-2.0, 3.5)
OCCUPIED_ABOVE = 0.7  # log-odds: probability 0.67
FREE_BELOW = -0.4  # probability 0.40
OCCUPIED_PERCENT = 67  # the same thresholds on the exported 0-100 scale
FREE_PERCENT = 40
HIT_DEPTH_M = RESOLUTION_M / 4
# Beams with no return clear the space in front of them up to this far (m).
NO_RETURN_CLEAR_M = 3.0


@dataclass(frozen=True)
class GridSpec:
    """Cell (i, j) covers x in [x0 + i res, x0 + (i+1) res), y likewise; i indexes x."""

    x0: float
    y0: float
    nx: int
    ny: int
    resolution: float = RESOLUTION_M

    @staticmethod
    def around(cx: float, cy: float, size_x: float, size_y: float, resolution: float = RESOLUTION_M) -> GridSpec:
        """A grid of at least this size around (cx, cy), with its cell centres on multiples of the resolution
        (so walls built on a 5 cm module fall inside cells, not on the lines between them)."""
        nx, ny = math.ceil(size_x / resolution), math.ceil(size_y / resolution)
        x0 = (round(cx / resolution) - nx // 2 - 0.5) * resolution
        y0 = (round(cy / resolution) - ny // 2 - 0.5) * resolution
        return GridSpec(x0, y0, nx, ny, resolution)

    def cell(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (
            np.floor((np.asarray(x) - self.x0) / self.resolution).astype(np.int64),
            np.floor((np.asarray(y) - self.y0) / self.resolution).astype(np.int64),
        )

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        xs = self.x0 + self.resolution * (np.arange(self.nx) + 0.5)
        ys = self.y0 + self.resolution * (np.arange(self.ny) + 0.5)
        return np.meshgrid(xs, ys, indexing="ij")


@dataclass(frozen=True)
class OccupancyGrid:
    """A snapshot to send around: `data` is (nx, ny) int8, 0-100 or -1 unknown, i indexing x."""

    spec: GridSpec
    data: np.ndarray
    sim_time_s: float
    scans: int

    def occupied(self) -> np.ndarray:
        return self.data >= OCCUPIED_PERCENT

    def free(self) -> np.ndarray:
        return (self.data >= 0) & (self.data <= FREE_PERCENT)

    def known(self) -> np.ndarray:
        return self.data >= 0


class OccupancyMapper:
    def __init__(self, spec: GridSpec) -> None:
        self.spec = spec
        self._log_odds = np.zeros((spec.nx, spec.ny), dtype=np.float32)
        self._seen = np.zeros((spec.nx, spec.ny), dtype=bool)
        self.scans = 0
        self.sim_time_s = 0.0

    def integrate(self, scan: LaserScan, x: float, y: float, yaw: float) -> None:
        """Add one scan taken by a sensor at (x, y) facing `yaw` (world frame)."""
        spec = self.spec
        angles = scan.angles() + yaw
        ranges = scan.ranges.astype(np.float64)
        hit = np.isfinite(ranges)
        reach = np.where(hit, ranges, NO_RETURN_CLEAR_M)
        # free space: samples every half cell along each beam, stopping half a cell short of the return
        step = spec.resolution / 2
        samples = np.arange(0.0, float(reach.max()), step)
        along = samples[None, :] < (reach[:, None] - step)
        px = x + samples[None, :] * np.cos(angles)[:, None]
        py = y + samples[None, :] * np.sin(angles)[:, None]
        beam = np.broadcast_to(np.arange(len(angles))[:, None], along.shape)[along]
        free = self._cells(px[along], py[along], beam)
        # a return lies on a surface, with the solid behind it: it is counted a little way in (range noise would
        # otherwise put half the returns from a surface on a cell boundary in the free cell before it)
        depth = ranges[hit] + HIT_DEPTH_M
        occupied = self._cells(x + depth * np.cos(angles[hit]), y + depth * np.sin(angles[hit]), np.nonzero(hit)[0])
        # each beam counts once per cell it crosses, and once where it ends: a cell near a surface that some beams
        # cross and others end in (range noise) weighs both
        size = spec.nx * spec.ny
        change = MISS * np.bincount(free, minlength=size) + HIT * np.bincount(occupied, minlength=size)
        flat = self._log_odds.reshape(-1)
        flat += change.astype(np.float32)
        seen = self._seen.reshape(-1)
        seen[free] = True
        seen[occupied] = True
        np.clip(self._log_odds, *CLAMP, out=self._log_odds)
        self.scans += 1
        self.sim_time_s = scan.sim_time_s

    def _cells(self, x: np.ndarray, y: np.ndarray, beam: np.ndarray) -> np.ndarray:
        """Flat indices of the cells under the points, each (beam, cell) pair once. The points come beam by beam
        in order along each beam, and a straight beam crosses a (convex) cell in one run of points: dropping a
        point in the same cell as the one before it leaves each pair once, without sorting (np.unique)."""
        i, j = self.spec.cell(x, y)
        inside = (i >= 0) & (i < self.spec.nx) & (j >= 0) & (j < self.spec.ny)
        cells = i[inside] * self.spec.ny + j[inside]
        beams = beam[inside]
        first = np.ones(len(cells), dtype=bool)
        first[1:] = (cells[1:] != cells[:-1]) | (beams[1:] != beams[:-1])
        return cells[first]

    def occupied(self) -> np.ndarray:
        return self._log_odds > OCCUPIED_ABOVE

    def free(self) -> np.ndarray:
        return self._seen & (self._log_odds < FREE_BELOW)

    def snapshot(self) -> OccupancyGrid:
        probability = 1.0 - 1.0 / (1.0 + np.exp(self._log_odds))
        data = np.where(self._seen, np.round(100 * probability), -1).astype(np.int8)
        return OccupancyGrid(self.spec, data, self.sim_time_s, self.scans)

    def clear(self) -> None:
        self._log_odds[:] = 0
        self._seen[:] = False
        self.scans = 0
