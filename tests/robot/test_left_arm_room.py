"""During a reach the left arm goes out sideways as a counterweight, unless the map shows something beside the
robot (a wall at the counter's end pushed it over): then it goes forward, clear of the floor all the same."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.manipulation.grasp_plan import (
    CROWDED_LEFT_OFFSET,
    GRASP_OFFSET,
    LEFT_ARM_FORWARD,
    LEFT_ARM_SIDEWAYS_ROOM_M,
    RAISE_SIDEWAYS,
    arm_out_moves,
    grasp_stance,
    reach_problem,
    room_on_left,
)


def wall_along_y(y_wall: float):
    return lambda x, y: y >= y_wall


def left_arm_targets(room: float) -> dict[str, float]:
    first = arm_out_moves(room)[0]
    return {n: v for n, v in first.positions.items() if n.startswith("l_")}


def test_room_is_measured_to_the_robots_left_whichever_way_it_faces() -> None:
    wall = wall_along_y(1.5)
    assert room_on_left(1.3, 1.26, 0.0, wall) == pytest.approx(0.24, abs=0.021)  # facing +x: left is +y
    assert room_on_left(1.3, 1.26, math.pi, wall) == LEFT_ARM_SIDEWAYS_ROOM_M  # facing -x: the wall is on the right
    assert room_on_left(0.0, 0.0, 0.0, lambda x, y: False) == LEFT_ARM_SIDEWAYS_ROOM_M


def test_the_left_arm_goes_out_sideways_with_room_and_forward_without() -> None:
    sideways = {n: v for n, v in RAISE_SIDEWAYS.items() if n.startswith("l_")}
    assert left_arm_targets(math.inf) == sideways
    assert left_arm_targets(LEFT_ARM_SIDEWAYS_ROOM_M) == sideways
    assert left_arm_targets(0.24) == LEFT_ARM_FORWARD
    # the right arm's moves are the same either way
    rest = [m.positions for m in arm_out_moves(0.24)[1:]]
    assert rest == [m.positions for m in arm_out_moves()[1:]]


def object_in_feet(stance, xy: tuple[float, float]) -> tuple[float, float]:
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    dx, dy = xy[0] - stance.x, xy[1] - stance.y
    return (c * dx + s * dy, -s * dx + c * dy)


def test_by_a_wall_on_the_left_the_robot_stands_further_right_with_the_object_still_in_reach() -> None:
    mug = (1.6, 1.15)  # 0.35 m from a wall along y = 1.5, as on world seed 5
    wall = wall_along_y(1.5)
    usual = grasp_stance(mug, 0.0)
    assert object_in_feet(usual, mug) == pytest.approx(GRASP_OFFSET)
    assert grasp_stance(mug, 0.0, lambda x, y: False) == usual  # nothing beside it: the usual stance
    crowded = grasp_stance(mug, 0.0, wall)
    assert object_in_feet(crowded, mug) == pytest.approx(CROWDED_LEFT_OFFSET)
    assert crowded.y < usual.y and room_on_left(crowded.x, crowded.y, 0.0, wall) > room_on_left(
        usual.x, usual.y, 0.0, wall
    )
    assert reach_problem(np.array([*object_in_feet(crowded, mug), 0.25])) is None
