"""Routes: orders to visit places in (the shortest-looking round from where the robot is: nearest first, then
nearest to that, on straight-line distances, good enough for a handful of places in one flat), and waypoints in
open floor near a place, clear of the walls and furniture the world model knows."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from robot.model.world import GRID_RESOLUTION, WorldLayout, is_mat, near_mat_edges, occupancy_grid

# A patrol's waypoint keeps this far from walls and furniture (the place's own staging point is only 26 cm from its
# surface, and the dock's sits in a corner): room for the robot to turn and for its estimate to be off; less where
# furniture crowds a place, rather than a waypoint further than `WAYPOINT_SHIFT_M` from it.
WAYPOINT_CLEARANCES_M = (0.45, 0.38, 0.3)
WAYPOINT_SHIFT_M = 0.4
# ... and keeps the feet off the edge of a mat on the floor (the dock's pad, 3 mm): the dock's waypoint sat on the
# pad's corner in 10 of 12 worlds, where the robot turns towards the next waypoint with one foot on the pad and one
# off (patrols with the arms held back, tried at stop 63, rocked 11 degrees there, and one fell): no waypoint
# within `FEET_REACH_M` of a mat's edge.


def nearest_first(start: tuple[float, float], points: Sequence[tuple[str, tuple[float, float]]]) -> list[str]:
    """The names of `points` in a greedy nearest-neighbour order from `start`."""
    left = list(points)
    order: list[str] = []
    here = start
    while left:
        name, point = min(left, key=lambda item: math.dist(here, item[1]))
        order.append(name)
        left.remove((name, point))
        here = point
    return order


def waypoint_near(layout: WorldLayout, point: tuple[float, float]) -> tuple[float, float]:
    """Open floor near `point` for a patrol to pass: the most clearance that stays within `WAYPOINT_SHIFT_M`."""
    for clearance in WAYPOINT_CLEARANCES_M:
        near = open_floor_near(layout, point, clearance)
        if math.dist(near, point) <= WAYPOINT_SHIFT_M:
            return near
    return point


def open_floor_near(layout: WorldLayout, point: tuple[float, float], clearance_m: float) -> tuple[float, float]:
    """The point of open floor nearest `point` that keeps `clearance_m` from the walls and furniture (the point
    itself if it does; the least crowded point near it if nowhere does)."""
    blocked, x0, y0 = occupancy_grid(layout, clearance_m)
    blocked = blocked | _mat_edges(layout, blocked.shape, x0, y0)
    free = np.argwhere(~blocked)
    if len(free) == 0:
        return point
    xy = np.column_stack([x0 + free[:, 0] * GRID_RESOLUTION, y0 + free[:, 1] * GRID_RESOLUTION])
    nearest = xy[int(np.argmin(np.hypot(xy[:, 0] - point[0], xy[:, 1] - point[1])))]
    return round(float(nearest[0]), 3), round(float(nearest[1]), 3)


def _mat_edges(layout: WorldLayout, shape: tuple[int, ...], x0: float, y0: float) -> np.ndarray:
    """The cells of the occupancy grid (`shape`, from `x0`, `y0`) where a standing robot would have a foot on a
    mat's edge."""
    gx, gy = np.meshgrid(
        x0 + GRID_RESOLUTION * np.arange(shape[0]), y0 + GRID_RESOLUTION * np.arange(shape[1]), indexing="ij"
    )
    return near_mat_edges((box for box in layout.furniture if is_mat(box)), gx, gy)
