"""The grid navigation plans on: the occupancy map's occupied cells grown by the robot's footprint and a margin.

Unknown cells count as free: the robot may walk into what it has not seen yet, and its lidar maps obstacles as
they come into view (the plan is checked against the map as it grows, and replanned when blocked).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot.interface import OccupancyMap
from robot.navigation.grid_planner import inflate

OCCUPIED_PERCENT = 67


@dataclass(frozen=True)
class Costmap:
    blocked: np.ndarray  # (nx, ny) bool, i along x
    x0: float
    y0: float
    resolution: float

    @staticmethod
    def from_map(grid: OccupancyMap, inflate_m: float) -> Costmap:
        data = np.frombuffer(grid.data, dtype=np.int8).reshape(grid.height, grid.width).T
        occupied = data >= OCCUPIED_PERCENT
        return Costmap(inflate(occupied, inflate_m / grid.resolution), grid.origin[0], grid.origin[1], grid.resolution)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """The x and y of every cell's centre, as two arrays shaped like `blocked`."""
        nx, ny = self.blocked.shape
        xs, ys = self.x0 + (np.arange(nx) + 0.5) * self.resolution, self.y0 + (np.arange(ny) + 0.5) * self.resolution
        return np.meshgrid(xs, ys, indexing="ij")  # type: ignore[return-value]

    def also_blocked(self, cells: np.ndarray) -> Costmap:
        """This costmap with `cells` (a bool array shaped like `blocked`) blocked too."""
        return Costmap(self.blocked | cells, self.x0, self.y0, self.resolution)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return int(np.floor((x - self.x0) / self.resolution)), int(np.floor((y - self.y0) / self.resolution))

    def centre(self, i: int, j: int) -> tuple[float, float]:
        return (self.x0 + (i + 0.5) * self.resolution, self.y0 + (j + 0.5) * self.resolution)

    def inside(self, i: int, j: int) -> bool:
        return 0 <= i < self.blocked.shape[0] and 0 <= j < self.blocked.shape[1]

    def blocked_at(self, x: float, y: float) -> bool:
        i, j = self.cell(x, y)
        return not self.inside(i, j) or bool(self.blocked[i, j])
