"""Standing up from a reach: the legs straighten while the arm swings back, as one joint move, so the body is never
upright with the arm still out in front (nor bent with it back)."""

from __future__ import annotations

import numpy as np

from robot.manipulation.arm_motion import JointMove, Move
from robot.manipulation.grasp_plan import Hand, for_hand, release_moves
from robot.model import humanoid_v1

STAND_UP_S = 1.5
REACHING_AHEAD_M = 0.15  # a hand this far ahead of the feet is reaching for something on a surface
SWING_BACK = {"r_sho_pitch": 1.57, "r_sho_roll": 0.0, "r_el": 1.8, "r_wrist": -0.9}
# The arm joints a move back to the standing posture sets (the wrist is already there): every one, so that the arms
# end where walking expects them (`WholeBodyIK.arms_at_rest`).
REST_ARM_JOINTS = ("r_sho_pitch", "r_sho_roll", "r_el", "l_sho_pitch", "l_sho_roll", "l_el")


def _legs_to(targets: np.ndarray, duration_s: float) -> JointMove:
    names = humanoid_v1.JOINT_NAMES
    return JointMove({n: float(targets[names.index(n)]) for n in humanoid_v1.LEG_JOINTS}, duration_s, "stand up")


def standing_up_with(moves: list[Move], stand: np.ndarray) -> list[Move]:
    """The legs back to the standing posture while the first (joint) arm move plays: one move, not two in a row
    (1.2-1.5 s saved each time the robot stands up from a reach)."""
    first, *rest = moves
    if not isinstance(first, JointMove):
        raise TypeError("standing up goes with a joint move: a hand move would have the solver move the legs")
    legs = _legs_to(stand, STAND_UP_S)
    both = JointMove(
        {**legs.positions, **first.positions}, max(STAND_UP_S, first.duration_s), f"stand up, {first.label}"
    )
    return [both, *rest]


def arm_back_moves(hand: Hand = "right") -> list[Move]:
    """The arm-out moves in reverse, ending in the standing arm posture with the gripper closed."""
    stand = humanoid_v1.stand_posture()
    moves: list[Move] = [
        JointMove({**SWING_BACK, "r_grip": 0.0}, 1.2, "swing back"),
        JointMove({"r_el": 0.0, "r_wrist": 0.0, "r_sho_pitch": 0.0}, 0.8, "unfold upright"),
        JointMove({n: stand[n] for n in REST_ARM_JOINTS}, 0.8, "arms to rest"),
    ]
    return for_hand(moves, hand)


def letting_go_out_in_front(hand_in_feet: np.ndarray) -> list[Move]:
    """Open, back away and rise clear before swinging back, when the hand is out in front reaching and holds
    nothing: it may be round an object it let go of or had not closed on yet (a pick or place stopped midway).
    Swung back from there, the arm knocked the mug over, or closed on it and swung it down to the hip. Nothing when
    the hand is not out in front."""
    hand = np.asarray(hand_in_feet, dtype=float)
    return release_moves(hand) if hand[0] >= REACHING_AHEAD_M else []
