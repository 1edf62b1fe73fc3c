"""`pick_object`: stand where the object is in reach, look at it again standing still, reach, grasp, lift, check.

Failures name their cause, so the executor and the operator can replan: "not found", "unreachable", "grasp
failed: closed on nothing", "grasp slipped", "fell", "path blocked".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robot.manipulation.arm_motion import Move
from robot.manipulation.grasp_plan import (
    EMPTY_GRIP_M,
    LIFT_M,
    Hand,
    Stance,
    arm_out_moves,
    grasp_moves,
    lift_moves,
    other_hand,
    reach_problem,
    release_moves,
)

# How many times the stance is corrected from a fresh sighting before the object counts as unreachable.
STANCE_ATTEMPTS = 3
# The lifted object must have risen at least this much (m) with the hand.
MIN_RISE_M = 0.03


class PickFailed(RuntimeError):
    pass


class PickBody(Protocol):
    """What picking needs of the robot (the worker implements it; tests may fake it)."""

    def locate(self, name: str) -> np.ndarray | None:
        """The object's base centre in the map from a fresh sighting while standing still, or None if not seen."""

    def to_feet(self, point_in_map: np.ndarray) -> np.ndarray: ...

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        """Walk to the stance (raises PickFailed with the navigation's reason); a stop short of it with the map point
        `reach` comfortably in the arm's reach will do."""

    def stance_for(self, point_in_map: np.ndarray, hand: Hand = "right") -> Stance:
        """Where to stand to grasp the object there: square to its surface, further right beside a wall on the left
        (`grasp_plan.grasp_stance` on the robot's map); for `hand` where it has room, else for the other one."""

    def sideways_clear(self, hand: Hand = "right") -> bool:
        """Whether nothing on the map stands where `hand`'s arm swings out sideways from where the robot stands
        (`grasp_plan.arm_sweep_taken`); True with no map yet."""

    def arm(self, moves: Sequence[Move], hand: Hand | None = None) -> None:
        """Play arm moves reaching with `hand` (None: the last one; the arm takes over the joints first) and return
        when they are done."""

    def grip_opening(self) -> float:
        """Measured opening of each finger of the reaching hand (m)."""

    def stand_holding(self) -> None:
        """Stand up with the arm as it is, and hand the legs back to walking."""

    def stow_arm(self) -> None:
        """Arm back down, gripper open, standing (after a failure)."""


@dataclass(frozen=True)
class PickReport:
    name: str
    grip_m: float
    rise_m: float
    stance_corrections: int
    hand: Hand = "right"


def pick(name: str, height: float, body: PickBody, round_object: bool = False) -> PickReport:
    """Pick up the object `name` (`height` tall, a ball if `round_object`); on failure the arm is stowed and
    PickFailed says why."""
    corrections = 0
    seen = body.locate(name)
    if seen is None:
        raise PickFailed(f"not found: the {name} is not where it was seen")
    # The left hand only where the right one has no room to stand; but a hand the object is in reach of already
    # grasps (the map grows as the robot walks: at world seed 39 a chair just behind the right hand's stance was
    # out of it once the robot stood at the left hand's, and walking over there, the left arm swung back into it).
    hand = body.stance_for(seen).hand
    for attempt in range(STANCE_ATTEMPTS + 1):
        in_feet = body.to_feet(seen)
        reaching = next((h for h in (hand, other_hand(hand)) if reach_problem(in_feet, h) is None), None)
        if reaching is not None:
            hand = reaching
            break
        if attempt == STANCE_ATTEMPTS:
            problem = reach_problem(in_feet, hand)
            raise PickFailed(f"unreachable: the {name} is {problem} after {corrections} stance corrections")
        stance = body.stance_for(seen, hand)
        hand = stance.hand
        body.go_to(stance, seen)
        corrections += 1
        seen = body.locate(name)
        if seen is None:
            raise PickFailed(f"not found: lost sight of the {name} at the counter")
    moves, grasp = grasp_moves(in_feet, height, round_object)
    try:
        body.arm([*arm_out_moves(body.sideways_clear(hand), hand), *moves], hand)
        grip = body.grip_opening()
        if grip < EMPTY_GRIP_M:
            raise PickFailed(f"grasp failed: the gripper closed on nothing ({grip * 2000:.0f} mm open)")
        body.arm(lift_moves(grasp, height))
        lifted = body.locate(name)
        rise = float(lifted[2] - seen[2]) if lifted is not None else float("nan")
        grip = body.grip_opening()
        if grip < EMPTY_GRIP_M or (lifted is not None and rise < MIN_RISE_M):
            risen = f"rose {rise * 100:.1f} of {LIFT_M * 100:.0f} cm" if lifted is not None else "out of sight"
            raise PickFailed(
                f"grasp slipped: the {name} did not rise with the hand ({risen}, gripper {grip * 2000:.0f} mm open)"
            )
    except PickFailed:
        body.arm(release_moves(grasp))
        body.stow_arm()
        raise
    body.stand_holding()
    return PickReport(name, grip, rise, corrections, hand)
