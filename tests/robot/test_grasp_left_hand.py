"""The left hand grasps where the right one has no room to stand: the mirror image of the right hand's stance and
moves (at world seed 4 a plant stands where the feet go for the apple, and the fetch gave up: "no room to stand")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.manipulation.arm_motion import JointMove
from robot.manipulation.grasp_plan import (
    GRASP_OFFSET,
    Stance,
    arm_out_moves,
    arm_sweep_taken,
    carry_moves,
    comfortably_in_reach,
    for_hand,
    grasp_stance,
    grasp_stance_facing_any,
    place_moves,
    reach_problem,
    stance_facings,
    stance_taken,
)
from robot.manipulation.stand_up import arm_back_moves
from robot.model import humanoid_v1
from robot.model.world import Box
from tests.robot.test_grasp_around_chair import at_the_counter, object_in_feet


def test_where_no_stance_for_the_right_hand_is_usable_the_left_hand_gets_the_mirror_image_one() -> None:
    counter, xy, blocked = at_the_counter(4, "green apple")
    facings = stance_facings(counter.approach[2], counter.surface, xy)
    for yaw in facings:  # every stance for the right hand: taken, or (turned) its arm would sweep into something
        right = grasp_stance(xy, yaw, blocked)
        assert stance_taken(right, blocked) or (yaw != facings[0] and arm_sweep_taken(right, blocked))

    stance = grasp_stance_facing_any(xy, facings, blocked)
    assert stance.hand == "left" and not stance_taken(stance, blocked)
    in_feet = object_in_feet(stance, xy, counter.surface.height)
    assert in_feet[:2] == pytest.approx((GRASP_OFFSET[0], -GRASP_OFFSET[1]), abs=0.07)  # ahead, to the left
    assert reach_problem(in_feet, "left") is None and comfortably_in_reach(in_feet, hand="left")
    assert reach_problem(in_feet) is not None  # not the right hand's: the windows do not overlap


def test_with_room_for_the_right_hand_the_right_hand_grasps() -> None:
    counter, xy, blocked = at_the_counter(4, "red mug")
    stance = grasp_stance_facing_any(xy, stance_facings(counter.approach[2], counter.surface, xy), blocked)
    assert stance.hand == "right" and not stance_taken(stance, blocked)
    assert grasp_stance(xy, 0.0, hand="left") == Stance(xy[0] - 0.31, xy[1] - 0.11, 0.0, "left")


def test_a_stance_with_something_where_the_other_hand_swings_behind_the_back_is_taken() -> None:
    """World seed 39: a chair 0.205 m behind the usual stance, outside the feet's footprint, and in the way of the
    other hand swung back for the crouch."""
    stance = Stance(1.32, 0.75, 0.0)
    chair_behind = Box("chair", x=1.035, y=0.826, half_x=0.08, half_y=0.093, height=0.32)
    assert not chair_behind.contains(stance.x - 0.2, stance.y + 0.18)  # clear of the footprint's corner
    assert stance_taken(stance, lambda x, y: chair_behind.contains(x, y))
    further_back = Box("chair", x=0.935, y=0.826, half_x=0.08, half_y=0.093, height=0.32)  # 0.305 m behind
    assert not stance_taken(stance, lambda x, y: further_back.contains(x, y))


def test_the_reach_window_of_the_left_hand_is_the_right_ones_mirror_image() -> None:
    assert reach_problem(np.array([0.31, 0.11, 0.25]), "left") is None
    assert reach_problem(np.array([0.31, -0.11, 0.25]), "left") == "-0.11 m to the side (reach +0.03 to +0.19 m)"
    assert reach_problem(np.array([0.40, 0.11, 0.25]), "left").endswith("ahead (reach 0.27-0.35 m)")
    assert not comfortably_in_reach(np.array([0.31, 0.02, 0.25]), hand="left")


def _joints(moves: list, start: dict[str, float]) -> dict[str, float]:
    """The joint targets after playing the joint moves from `start`."""
    posture = dict(start)
    for move in moves:
        if isinstance(move, JointMove):
            posture.update(move.positions)
    return posture


@pytest.mark.parametrize(
    "moves",
    [
        lambda hand: arm_out_moves(True, hand),
        lambda hand: arm_out_moves(False, hand),
        lambda hand: carry_moves(hand),
        lambda hand: arm_back_moves(hand),
        lambda hand: place_moves(np.array([0.31, 0.11 if hand == "left" else -0.11, 0.25]), 0.05, hand=hand)[0],
    ],
    ids=["arm out sideways", "arm out in front", "carry", "arm back", "place"],
)
def test_the_left_arm_plays_the_right_arms_moves_in_mirror_image(moves) -> None:
    stand = humanoid_v1.stand_posture()
    right, left = moves("right"), moves("left")
    assert [m.label for m in left] == [m.label for m in right] and len(left) == len(right)
    assert [m.duration_s for m in left] == [m.duration_s for m in right]
    end_right, end_left = _joints(right, stand), _joints(left, stand)
    for name, value in end_right.items():
        side, _, joint = name.partition("_")
        if side in ("l", "r") and joint in ("sho_pitch", "sho_roll", "el", "wrist", "grip"):
            other = f"{'l' if side == 'r' else 'r'}_{joint}"
            assert end_left[other] == pytest.approx(humanoid_v1.mirror_arm_joints({name: value})[other])
    for r, m in zip(right, left, strict=True):  # hand moves are targets in the feet frame already: the same
        if not isinstance(r, JointMove):
            assert m == r or m.target[1] == pytest.approx(-r.target[1])
    assert for_hand(right, "right") == right


class FakePickBody:
    """A robot facing +x with its feet at `feet` that walks where it is told, whose map has room for the right hand
    only at `right_room` (else the stances it gives are the left hand's), and whose gripper closes on the object."""

    def __init__(self, feet: tuple[float, float], right_room: bool) -> None:
        self.feet = np.array([feet[0], feet[1], 0.0])
        self.right_room = right_room
        self.walks: list[Stance] = []
        self.arm_hands: list[str | None] = []
        self.lifted = False

    def locate(self, name: str) -> np.ndarray:
        return OBJECT + (np.array([0.0, 0.0, 0.05]) if self.lifted else 0.0)

    def to_feet(self, point_in_map: np.ndarray) -> np.ndarray:
        return np.asarray(point_in_map, dtype=float) - self.feet

    def stance_for(self, point_in_map: np.ndarray, hand: str = "right") -> Stance:
        usable = hand if hand == "left" or self.right_room else "left"
        return grasp_stance((float(point_in_map[0]), float(point_in_map[1])), 0.0, hand=usable)

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        self.walks.append(stance)
        self.feet = np.array([stance.x, stance.y, 0.0])

    def sideways_clear(self, hand: str = "right") -> bool:
        return True

    def arm(self, moves, hand: str | None = None) -> None:
        self.arm_hands.append(hand)
        self.lifted = any(m.label == "lift" for m in moves) or self.lifted

    def grip_opening(self) -> float:
        return 0.015

    def stand_holding(self) -> None: ...

    def stow_arm(self) -> None: ...


OBJECT = np.array([1.6, 0.5, 0.25])


def test_a_pick_walks_to_the_left_hands_stance_only_where_the_right_hand_has_no_room() -> None:
    from robot.manipulation.pick import pick

    far = (1.0, 0.3)
    roomy = FakePickBody(far, right_room=True)
    assert pick("red mug", 0.05, roomy).hand == "right"
    assert [w.hand for w in roomy.walks] == ["right"] and set(roomy.arm_hands) - {None} == {"right"}

    cramped = FakePickBody(far, right_room=False)
    report = pick("red mug", 0.05, cramped)
    assert report.hand == "left" and [w.hand for w in cramped.walks] == ["left"]
    assert set(cramped.arm_hands) - {None} == {"left"}  # None: the hand that reached last
    assert cramped.to_feet(OBJECT)[:2] == pytest.approx((GRASP_OFFSET[0], -GRASP_OFFSET[1]))


def test_a_hand_the_object_is_in_reach_of_already_grasps_without_walking() -> None:
    """The map grows as the robot walks: at world seed 39 the right hand's stance was free once the robot stood at
    the left hand's, and walking over there the left arm swung back into the chair behind it."""
    from robot.manipulation.pick import pick

    at_left_stance = (OBJECT[0] - GRASP_OFFSET[0], OBJECT[1] + GRASP_OFFSET[1])
    body = FakePickBody(at_left_stance, right_room=True)
    report = pick("red mug", 0.05, body)
    assert report.hand == "left" and body.walks == [] and report.stance_corrections == 0


@pytest.mark.slow
def test_a_fetch_of_the_apple_where_a_plant_stands_by_the_counter_picks_it_with_the_left_hand() -> None:
    """In physics, world seed 4: a plant stands where the feet go for the apple and a box beside the counter's end.
    The fetch picks the apple with the left hand and brings it back, never saying "no room", never touching the
    plant or the box (the counter at most with a fingertip); it says "here it is" only with the apple in the left
    hand. (As with the right hand, an apple that slips out on the way back is said so, and that ending is accepted
    here.)"""
    from harness.behaviour_judge import run_judged
    from robot.interface import BehaviourState
    from robot.model.scene import object_body_name

    status, judge = run_judged("fetch", {"object": "green apple"}, 4)
    assert status is not None and any(line.startswith("carrying the green apple") for line in status.feedback)
    assert not any("no room" in line for line in status.feedback)
    assert [c["what"] for c in judge.collisions if "plant" in c["what"] or "box" in c["what"]] == []
    # the counter: at most a fingertip on its edge as the hand comes over it in front (the right hand's way out in
    # front came 1 cm into the edge at worst; a CI run under load saw a left finger brush it once), never the arm
    counter = [c["what"] for c in judge.collisions if "kitchen_counter" in c["what"]]
    assert [what for what in counter if "finger" not in what] == []
    data = judge.backend.data
    apple = data.body(object_body_name("green apple")).xpos
    in_left_hand = math.dist(apple, data.site("left_hand").xpos) < 0.06
    if status.state == BehaviourState.SUCCEEDED:
        assert "here it is" in status.feedback[-1] and in_left_hand
    else:
        assert status.reason.startswith("the green apple is no longer in my hand"), status.reason
        assert not in_left_hand
