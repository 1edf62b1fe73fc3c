"""Grasping at a counter's end, beside a wall: the robot stands further right, and its left arm, swung back during
the reach, stays within the body's width (out sideways it pushed the wall and the robot over) and off the floor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.control.gait import write_placo_model
from robot.manipulation.arm_motion import ArmMotion
from robot.manipulation.grasp_plan import (
    CARRY_ARM,
    CROWDED_LEFT_OFFSET,
    GRASP_OFFSET,
    LEFT_ARM_BACK,
    REACH_SURFACE_Z,
    REACH_X,
    REACH_Y,
    STANCE_LEFT_ROOM_M,
    arm_out_moves,
    grasp_moves,
    grasp_stance,
    lift_moves,
    place_moves,
    reach_problem,
    room_on_left,
)
from robot.manipulation.reach_ik import ReachIK
from robot.model import humanoid_v1


def wall_along_y(y_wall: float):
    return lambda x, y: y >= y_wall


def test_room_is_measured_to_the_robots_left_whichever_way_it_faces() -> None:
    wall = wall_along_y(1.5)
    assert room_on_left(1.3, 1.26, 0.0, wall) == pytest.approx(0.24, abs=0.021)  # facing +x: left is +y
    assert room_on_left(1.3, 1.26, math.pi, wall) == STANCE_LEFT_ROOM_M  # facing -x: the wall is on the right
    assert room_on_left(0.0, 0.0, 0.0, lambda x, y: False) == STANCE_LEFT_ROOM_M


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


@pytest.fixture(scope="module")
def reach_ik(tmp_path_factory) -> ReachIK:
    return ReachIK(write_placo_model(tmp_path_factory.mktemp("placo")), 0.01)


@pytest.mark.parametrize(
    "mug_in_feet",
    [(REACH_X[1], REACH_Y[1], REACH_SURFACE_Z[0]), (REACH_X[0], REACH_Y[0], REACH_SURFACE_Z[0]), (0.31, -0.11, 0.25)],
)
def test_the_left_hand_stays_within_the_bodys_width_and_off_the_floor_through_the_reach(
    reach_ik: ReachIK, mug_in_feet: tuple[float, float, float]
) -> None:
    """Kinematic replay of the whole reach (arm out, pre-grasp, approach, close, lift), down to the lowest surface
    in reach, where the crouch is deepest."""
    grasp, point = grasp_moves(np.array(mug_in_feet), 0.08)
    motion = ArmMotion(reach_ik, 0.01)
    joints = np.array([humanoid_v1.stand_posture()[n] for n in humanoid_v1.JOINT_NAMES])
    motion.start(joints, "right")
    motion.queue(*arm_out_moves(), *grasp, *lift_moves(point, 0.08))
    left_hand = []
    for _ in range(5000):
        joints = motion.update(joints)
        left_hand.append(reach_ik.hand_position(joints, side="left"))
        if motion.done.is_set():
            break
    assert motion.done.is_set()
    left_hand = np.array(left_hand)
    assert left_hand[:, 1].max() < left_hand[0, 1] + 0.005  # never further out than it hangs when standing
    assert left_hand[:, 2].min() > 0.04  # clear of the floor (out sideways: 0.32 m out; hanging or forward: < 0)
    assert np.abs(motion.commanded_hand() - point - [0, 0, 0.05]).max() < 1e-6  # the right hand did lift


@pytest.mark.parametrize("surface_z", [REACH_SURFACE_Z[0], 0.2])
def test_the_left_arm_holds_still_while_the_right_hand_sets_an_object_down(reach_ik: ReachIK, surface_z: float) -> None:
    """The reaching solver balances with the legs, not the other arm: left free, it rolled the left arm in against
    the trunk while a mug was set down on the table, until the shoulder servo overloaded and the robot stopped."""
    moves, _ = place_moves(np.array([0.31, -0.11, surface_z]), 0.08)
    motion = ArmMotion(reach_ik, 0.01)
    joints = np.array([{**humanoid_v1.stand_posture(), **CARRY_ARM}[n] for n in humanoid_v1.JOINT_NAMES])
    motion.start(joints, "right")
    motion.queue(*moves)
    left = [humanoid_v1.JOINT_NAMES.index(n) for n in LEFT_ARM_BACK]
    held = np.array(list(LEFT_ARM_BACK.values()))
    swung_back = False
    for _ in range(5000):
        joints = motion.update(joints)
        swung_back = swung_back or np.allclose(joints[left], held)
        if swung_back:
            assert np.allclose(joints[left], held, atol=1e-6)
        if motion.done.is_set():
            break
    assert motion.done.is_set() and swung_back
