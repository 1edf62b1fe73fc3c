"""Placing, replayed through the reach solver: after letting go the hand rises clear of the object without the robot
crouching deeper. With the hand sent 10 cm back and 10 cm up, it came near the shoulder, out of reach, and the
solver dropped the trunk instead; in physics the robot then pitched 9 deg and fell standing up (world seeds 0, 29)."""

from __future__ import annotations

import numpy as np
import pytest

from robot.control.gait import write_placo_model
from robot.manipulation.arm_motion import ArmMotion
from robot.manipulation.grasp_plan import CARRY_ARM, GRASP_OFFSET, REACH_SURFACE_Z, place_moves
from robot.manipulation.reach_ik import ReachIK
from robot.model import humanoid_v1

DT = 0.01


@pytest.fixture(scope="module")
def placo_model(tmp_path_factory):
    return write_placo_model(tmp_path_factory.mktemp("placo"))


@pytest.mark.parametrize("surface_height", [REACH_SURFACE_Z[0], 0.20, 0.25, 0.30])
def test_after_letting_go_the_hand_rises_clear_and_the_trunk_does_not_sink(placo_model, surface_height: float) -> None:
    moves, release = place_moves(np.array([*GRASP_OFFSET, surface_height]), object_height=0.05)
    carrying = {**humanoid_v1.stand_posture(), **CARRY_ARM}
    joints = np.array([carrying[n] for n in humanoid_v1.JOINT_NAMES])
    ik = ReachIK(placo_model, DT)
    motion = ArmMotion(ik, DT)
    motion.start(joints, "right")
    motion.queue(*moves)
    trunk: dict[str, list[float]] = {}
    for move in moves:
        for _ in range(round(move.duration_s / DT)):
            joints = motion.update(joints)  # the servos do as told: measured = commanded
            trunk.setdefault(move.label, []).append(ik.trunk_height())
    assert motion.done.is_set()
    after_release = trunk["open"] + trunk["back away"] + trunk["clear"]
    assert min(after_release) > min(trunk["set down"]) - 0.005
    hand = ik.hand_position(joints)
    assert hand[2] > release[2] + 0.05  # above the object's top (2 cm above the release point for this mug)
    assert hand[0] < release[0] - 0.04  # and behind it
