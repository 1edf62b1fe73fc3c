"""Turning about in place, the hands sweep round the trunk: the way round is the one that passes them farthest from
what is near (a patrol turning about between a wall and a table put its fingers on the table, world seed 18)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.navigation.follower import PathFollower
from robot.navigation.turn_sweep import FINGER_BEARING_RAD, swept, turn_way

# In the robot's frame (x ahead, y to the left): a wall 0.28 m to its left, a table's corner 0.2 m to its right.
WALL_LEFT = np.array([(x, 0.28) for x in np.arange(-0.3, 0.31, 0.05)])
TABLE_RIGHT = np.array([(0.0, -0.2), (0.05, -0.21), (0.1, -0.25)])


def test_a_quarter_turn_sweeps_only_what_lies_between_the_fingers_start_and_end() -> None:
    behind_left, ahead_left = FINGER_BEARING_RAD + 0.1, math.radians(60.0)
    turned = swept(np.array([behind_left, ahead_left]), math.pi / 2)  # anticlockwise: the left finger goes round
    assert turned.tolist() == [True, False]  # to behind the robot ... and not round to ahead of it
    assert swept(np.array([ahead_left]), -math.pi / 2).tolist() == [True]  # clockwise, the right finger comes round


def test_a_turn_about_between_a_wall_and_a_table_goes_the_way_round_that_keeps_the_fingers_off_the_table() -> None:
    near = np.vstack([WALL_LEFT, TABLE_RIGHT])
    assert turn_way(near, math.radians(177.0)) == -1.0  # the shorter way (anticlockwise) sweeps the table's corner
    mirrored = near * (1.0, -1.0)
    assert turn_way(mirrored, math.radians(-177.0)) == 1.0


@pytest.mark.parametrize("error_deg", [177.0, -177.0, 90.0, -120.0])
def test_with_nothing_near_or_for_less_than_a_turn_about_the_shorter_way_is_taken(error_deg: float) -> None:
    assert turn_way(np.zeros((0, 2)), math.radians(error_deg)) == math.copysign(1.0, error_deg)
    if abs(error_deg) < 150.0:
        assert turn_way(TABLE_RIGHT, math.radians(error_deg)) == math.copysign(1.0, error_deg)


def test_the_follower_turns_about_the_way_it_is_told_until_the_path_is_ahead() -> None:
    path = [
        (0.0, 0.0),
        (0.02, -1.0),
    ]  # behind a robot facing +y, a little to its left: the shorter way is anticlockwise
    follower = PathFollower(path)
    assert follower.first_heading_error(0.0, 0.0, math.radians(93.0)) > math.radians(170.0)
    assert follower.update(0.0, 0.0, math.radians(93.0)).yaw_rate > 0.0
    follower = PathFollower(path)
    follower.turn_way = -1.0
    for yaw_deg in (93.0, 60.0, 0.0, -45.0):  # clockwise round, past the half turn
        command = follower.update(0.0, 0.0, math.radians(yaw_deg))
        assert command.yaw_rate < 0.0 and command.vx == 0.0
    assert follower.update(0.0, 0.0, math.radians(-95.0)).vx > 0.0  # the path ahead: walking on it
