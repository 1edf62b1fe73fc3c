"""Where to stand to pick something up, when something stands there: the robot stands elsewhere in the arm's reach
if it can, and otherwise says so at once (at world seed 0 a chair stands where it must stand for the apple: it
pushed the chair for 30 s, then gave up "stuck"; it now goes round the counter's end, tests/robot/
test_grasp_around_chair.py)."""

from __future__ import annotations

import math

import numpy as np

from robot.manipulation.grasp_plan import GRASP_OFFSET, comfortably_in_reach, grasp_stance, stance_taken


def box(x0: float, x1: float, y0: float, y1: float):
    return lambda x, y: x0 <= x <= x1 and y0 <= y <= y1


def in_feet(stance, xy: tuple[float, float]) -> tuple[float, float]:
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    dx, dy = xy[0] - stance.x, xy[1] - stance.y
    return (c * dx + s * dy, -s * dx + c * dy)


def test_a_small_thing_on_the_usual_stance_moves_the_robot_elsewhere_in_reach() -> None:
    apple = (1.66, 0.0)
    usual = grasp_stance(apple, 0.0)
    assert np.allclose(in_feet(usual, apple), GRASP_OFFSET)
    stool = box(usual.x - 0.05, usual.x + 0.05, usual.y + 0.17, usual.y + 0.3)  # by the left hand
    assert stance_taken(usual, stool)
    moved = grasp_stance(apple, 0.0, stool)
    assert not stance_taken(moved, stool) and moved.yaw == usual.yaw
    assert comfortably_in_reach(np.array([*in_feet(moved, apple), 0.25]))


def test_with_no_free_stance_in_reach_the_stance_stays_taken_for_the_caller_to_refuse() -> None:
    apple = (1.66, 0.0)
    chair = box(1.21, 1.45, 0.04, 0.19)  # world seed 0's chair, in front of the apple
    stance = grasp_stance(apple, 0.0, chair)
    assert stance_taken(stance, chair)
    assert not stance_taken(stance, lambda x, y: False)


def test_a_fetch_with_no_room_to_stand_anywhere_gives_up_at_once_without_pushing_anything() -> None:
    """World seed 6: the bottle stands at the counter's end, a box in front of it and the wall beyond."""
    from harness.behaviour_judge import run_judged
    from robot.interface import BehaviourState

    status, judge = run_judged("fetch", {"object": "blue bottle"}, 6)
    assert status is not None and status.state == BehaviourState.FAILED
    assert status.reason.startswith("no room to stand where the hand reaches the blue bottle"), status.reason
    assert [c for c in judge.collisions if "obj_" not in c["what"]] == []
    # it did not try for long (simulated time, not a timing of this machine)
    assert status.ended_sim_s is not None and status.ended_sim_s - status.started_sim_s < 30.0
