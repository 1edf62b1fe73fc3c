"""Grid paths and the path follower (the parts of navigation the mapping tour already uses)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from robot.navigation.follower import MAX_FORWARD_M_S, MAX_TURN_RAD_S, PathFollower
from robot.navigation.grid_planner import astar, inflate, simplify


def test_astar_goes_around_a_wall_through_its_gap_without_cutting_corners() -> None:
    blocked = np.zeros((20, 20), dtype=bool)
    blocked[10, :] = True
    blocked[10, 15] = False  # the only gap
    path = astar(blocked, (2, 2), (18, 2))
    assert path is not None and path[0] == (2, 2) and path[-1] == (18, 2)
    assert (10, 15) in path
    for (i, j), (a, b) in itertools.pairwise(path):
        assert max(abs(a - i), abs(b - j)) == 1 and not blocked[a, b]
        if a != i and b != j:
            assert not blocked[a, j] and not blocked[i, b]


def test_astar_says_none_when_the_goal_is_walled_off_or_blocked() -> None:
    blocked = np.zeros((10, 10), dtype=bool)
    blocked[4:7, 4:7] = True
    blocked[5, 5] = False
    assert astar(blocked, (0, 0), (5, 5)) is None  # enclosed
    assert astar(blocked, (0, 0), (4, 4)) is None  # inside an obstacle
    with pytest.raises(ValueError, match="outside the grid"):
        astar(blocked, (0, 0), (10, 3))


def test_inflation_is_a_disc_around_each_blocked_cell() -> None:
    blocked = np.zeros((21, 21), dtype=bool)
    blocked[10, 10] = True
    grown = inflate(blocked, 3.0)
    assert grown[13, 10] and grown[10, 7] and grown[12, 12]
    assert not grown[13, 13]  # the corner of the square is farther than 3 cells
    assert grown.sum() == sum(1 for i in range(-3, 4) for j in range(-3, 4) if i * i + j * j <= 9)


def test_simplify_keeps_only_the_corners_of_a_free_path() -> None:
    path = [(0.0, y * 0.1) for y in range(11)] + [(x * 0.1, 1.0) for x in range(1, 11)]
    assert simplify(path, lambda x, y: x > 0.05 and y < 0.95, 0.02) == [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0)]


def test_follower_brings_a_unicycle_to_the_goal_within_its_limits() -> None:
    follower = PathFollower([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)])
    x, y, yaw, dt = 0.0, 0.0, math.pi, 0.1  # starts facing away: it must turn in place first
    for _ in range(2000):
        command = follower.update(x, y, yaw)
        if command.arrived:
            break
        assert 0.0 <= command.vx <= MAX_FORWARD_M_S + 1e-9 and abs(command.yaw_rate) <= MAX_TURN_RAD_S + 1e-9
        x += command.vx * math.cos(yaw) * dt
        y += command.vx * math.sin(yaw) * dt
        yaw += command.yaw_rate * dt
    assert command.arrived and math.dist((x, y), (1.0, 1.0)) < 0.1


def test_follower_keeps_to_the_path_round_a_corner() -> None:
    """A robot that cut corners would walk into what the path goes round."""
    follower = PathFollower([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)])
    x, y, yaw, dt = 0.0, 0.0, 0.0, 0.1
    worst = 0.0
    for _ in range(2000):
        command = follower.update(x, y, yaw)
        if command.arrived:
            break
        x += command.vx * math.cos(yaw) * dt
        y += command.vx * math.sin(yaw) * dt
        yaw += command.yaw_rate * dt
        worst = max(worst, min(abs(y) if x <= 1.0 else math.inf, abs(x - 1.0) if y >= 0.0 else math.inf))
    assert command.arrived
    assert worst < 0.1  # never more than 10 cm off the path
