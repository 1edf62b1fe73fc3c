"""What a patrol notices on its map and in its memory: a new obstacle once, not the edges of what was there."""

from __future__ import annotations

import numpy as np

from robot.behaviours.builtin.changes import ChangeWatch
from robot.interface import KnownObject, OccupancyMap


def grid(cells: np.ndarray) -> OccupancyMap:
    return OccupancyMap(0.0, 0.05, (-1.0, -1.0), cells.shape[1], cells.shape[0], cells.astype(np.int8).tobytes(), 1)


def test_a_new_obstacle_on_free_floor_is_reported_once_where_it_is() -> None:
    cells = np.zeros((40, 40))
    cells[:, :3] = 100  # a wall, there from the start
    cells[30:, 30:] = -1  # not seen yet
    watch = ChangeWatch()
    watch.learn(grid(cells))
    assert watch.new_obstacles(grid(cells)) == []
    later = cells.copy()
    later[20:23, 10:13] = 100  # a box on the floor
    later[35:, 35:] = 100  # something where nothing was known: not judged
    later[:, 3] = 80  # the wall's edge, seen again: it was not free
    found = watch.new_obstacles(grid(later))
    assert len(found) == 1
    assert abs(found[0].x - (-1.0 + 11.5 * 0.05)) < 1e-6 and abs(found[0].y - (-1.0 + 21.5 * 0.05)) < 1e-6
    assert watch.new_obstacles(grid(later)) == []  # said once


def test_lidar_noise_of_a_cell_or_two_is_not_an_obstacle() -> None:
    cells = np.zeros((20, 20))
    watch = ChangeWatch()
    watch.learn(grid(cells))
    cells[5, 5] = cells[5, 6] = 100
    assert watch.new_obstacles(grid(cells)) == []


def test_an_object_seen_elsewhere_has_moved() -> None:
    watch = ChangeWatch()
    mug = KnownObject("red mug", (1.6, 0.7, 0.25), "kitchen counter", 1.0, 0.9)
    assert watch.moved_objects((mug,)) == []
    nudged = KnownObject("red mug", (1.65, 0.7, 0.25), "kitchen counter", 5.0, 0.9)
    assert watch.moved_objects((nudged,)) == []  # within what the camera's estimate wanders
    moved = KnownObject("red mug", (-1.2, 0.7, 0.2), "living-room table", 9.0, 0.9)
    [(obj, distance)] = watch.moved_objects((moved,))
    assert obj.place == "living-room table" and distance > 2.5
