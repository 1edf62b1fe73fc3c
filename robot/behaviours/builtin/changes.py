"""What a patrol notices: cells of the lidar map that were free once the first lap was done and are now taken (a
new obstacle), and objects the world memory now places elsewhere than where this patrol first saw them (an object
moved). The first lap only learns: a map seen once, from afar, marks the edges of furniture free where grazing
rays passed them, and those are not new; nor is an obstacle that grows at its edge (cells taken within
`EDGE_CELLS` of what was taken), so a box dropped against a wall goes unreported."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from robot.interface import KnownObject, OccupancyMap

FREE_AT_MOST = 20  # a cell at or below this (0-100) when the lap was learnt was free
TAKEN_AT_LEAST = 67  # ... and is now an obstacle at or above this
MIN_CELLS = 3  # fewer new cells together are lidar noise
EDGE_CELLS = 2  # new cells this close to cells taken when the lap was learnt are that obstacle's edge
SAME_OBSTACLE_M = 0.35  # a new obstacle this close to one reported already is that one
MOVED_M = 0.15  # an object seen this far from where it was first seen has moved


@dataclass(frozen=True)
class NewObstacle:
    x: float
    y: float
    cells: int


@dataclass
class ChangeWatch:
    """Remembers the map and the objects as first seen, and tells what is new since (each change once)."""

    first: np.ndarray | None = None  # each cell as learnt (-1: not known then, so never judged)
    shape: tuple[int, int, float, float, float] | None = None
    reported: list[tuple[float, float]] = field(default_factory=list)
    objects: dict[str, tuple[float, float]] = field(default_factory=dict)
    moved: set[str] = field(default_factory=set)

    def learn(self, grid: OccupancyMap | None) -> None:
        """The map as it is now is how the place should look (during the first lap)."""
        if grid is not None:
            self.first, self.shape = _cells(grid), _shape(grid)

    def new_obstacles(self, grid: OccupancyMap | None) -> list[NewObstacle]:
        if grid is None:
            return []
        cells = _cells(grid)
        if self.first is None or self.shape != _shape(grid):
            self.first, self.shape = cells, _shape(grid)
            return []
        fresh = (self.first >= 0) & (self.first <= FREE_AT_MOST) & (cells >= TAKEN_AT_LEAST)
        fresh &= ~_grown(self.first >= TAKEN_AT_LEAST, EDGE_CELLS)
        found = []
        for members in _clusters(fresh):
            if len(members) < MIN_CELLS:
                continue
            j, i = np.mean(members, axis=0)
            x = grid.origin[0] + (i + 0.5) * grid.resolution
            y = grid.origin[1] + (j + 0.5) * grid.resolution
            if any(math.dist((x, y), seen) < SAME_OBSTACLE_M for seen in self.reported):
                continue
            self.reported.append((x, y))
            found.append(NewObstacle(float(x), float(y), len(members)))
        return found

    def moved_objects(self, known: tuple[KnownObject, ...]) -> list[tuple[KnownObject, float]]:
        """Objects now remembered away from where this patrol first saw them, with how far (m)."""
        moved = []
        for obj in known:
            first = self.objects.setdefault(obj.name, obj.position[:2])
            distance = math.dist(first, obj.position[:2])
            if distance > MOVED_M and obj.name not in self.moved:
                self.moved.add(obj.name)
                moved.append((obj, distance))
        return moved


def _cells(grid: OccupancyMap) -> np.ndarray:
    return np.frombuffer(grid.data, dtype=np.int8).reshape(grid.height, grid.width).astype(np.int16)


def _shape(grid: OccupancyMap) -> tuple[int, int, float, float, float]:
    return (grid.width, grid.height, grid.resolution, *grid.origin)


def _grown(mask: np.ndarray, cells: int) -> np.ndarray:
    """`mask` grown by `cells` in every direction (a square)."""
    padded = np.pad(mask, cells)
    rows, cols = mask.shape
    grown = np.zeros_like(mask)
    for dr in range(2 * cells + 1):
        for dc in range(2 * cells + 1):
            grown |= padded[dr : dr + rows, dc : dc + cols]
    return grown


def _clusters(mask: np.ndarray) -> list[list[tuple[int, int]]]:
    """8-connected groups of True cells, as (row, column) lists."""
    seen = np.zeros_like(mask, dtype=bool)
    groups = []
    for start in zip(*np.nonzero(mask), strict=True):
        if seen[start]:
            continue
        group, stack = [], [start]
        seen[start] = True
        while stack:
            r, c = stack.pop()
            group.append((int(r), int(c)))
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    n = (r + dr, c + dc)
                    if 0 <= n[0] < mask.shape[0] and 0 <= n[1] < mask.shape[1] and mask[n] and not seen[n]:
                        seen[n] = True
                        stack.append(n)
        groups.append(group)
    return groups
