"""`place_object`: where on a surface the held object goes (in front of the place, or anywhere in reach of where the
robot stopped), and the placing procedure's checks and failures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.manipulation.arm_motion import HandMove, JointMove, Move
from robot.manipulation.grasp_plan import GRASP_OFFSET, REACH_MARGIN_M, REACH_X, Stance
from robot.manipulation.place import (
    EDGE_MARGIN_M,
    PLACE_DEPTH_M,
    SPACING_M,
    PlaceFailed,
    choose_spot,
    place,
    spots_in_reach,
)
from robot.model.world import Box

TABLE = Box("table", x=-1.2, y=0.75, half_x=0.3, half_y=0.25, height=0.2)
FACING_TABLE = (-1.2, 0.38, math.pi / 2)  # in front of its near edge (y = 0.5), facing it


def test_the_spot_is_in_front_of_the_robot_a_little_in_from_the_edge_at_the_surface_height() -> None:
    spot = choose_spot(TABLE, FACING_TABLE, [])
    assert spot is not None
    assert spot == pytest.approx([-1.2, 0.5 + PLACE_DEPTH_M, 0.2])


def test_the_spot_moves_aside_from_what_already_stands_there() -> None:
    spot = choose_spot(TABLE, FACING_TABLE, [(-1.2, 0.57)])
    assert spot is not None
    assert math.dist(spot[:2], (-1.2, 0.57)) >= SPACING_M - 1e-9
    assert spot[1] == pytest.approx(0.5 + PLACE_DEPTH_M)  # still at the same depth, only sideways
    assert TABLE.contains(float(spot[0]), float(spot[1]))


def test_a_full_surface_or_one_not_ahead_has_no_spot() -> None:
    along_the_edge = [(-1.5 + 0.04 * i, 0.57) for i in range(16)]
    assert choose_spot(TABLE, FACING_TABLE, along_the_edge) is None
    assert choose_spot(TABLE, (-1.2, 0.38, -math.pi / 2), []) is None  # facing away from it


class FakeBody:
    """A robot that stands where it is told (feet frame = map shifted to its feet, facing +x) and sees the placed
    object wherever the test says."""

    def __init__(self, feet: tuple[float, float], seen_after: np.ndarray | None) -> None:
        self.feet = np.array([feet[0], feet[1], 0.0])
        self.seen_after = seen_after
        self.stances: list[Stance] = []
        self.moves: list[Move] = []
        self.hands: list[str | None] = []
        self.stowed = False

    def locate(self, name: str, near: np.ndarray | None = None) -> np.ndarray | None:
        return self.seen_after

    def to_feet(self, point_in_map: np.ndarray) -> np.ndarray:
        return np.asarray(point_in_map, dtype=float) - self.feet

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        self.stances.append(stance)
        self.feet = np.array([stance.x, stance.y, 0.0])

    def arm(self, moves: list[Move], hand: str | None = None) -> None:
        self.moves.extend(moves)
        self.hands.append(hand)

    def stow_arm(self, finish_in_background: bool = False) -> None:
        self.stowed = True


SPOT = np.array([1.0, 0.5, 0.25])
IN_REACH = (SPOT[0] - GRASP_OFFSET[0], SPOT[1] - GRASP_OFFSET[1])


def test_placing_lowers_the_object_onto_the_spot_then_opens_backs_away_and_stows_the_arm() -> None:
    body = FakeBody(IN_REACH, seen_after=SPOT + np.array([0.01, 0.0, 0.0]))
    report = place("red mug", 0.05, SPOT, 0.0, body)
    assert body.stances == []  # already in reach: no stance correction
    labels = [m.label for m in body.moves]
    assert labels.index("over the spot") < labels.index("set down") < labels.index("open") < labels.index("clear")
    set_down = next(m for m in body.moves if m.label == "set down")
    assert isinstance(set_down, HandMove) and set_down.gripper == 0.0  # still holding while lowering
    assert set_down.target[2] == pytest.approx(SPOT[2] - body.feet[2] + 0.03 + 0.004, abs=1e-3)
    opened = next(m for m in body.moves if m.label == "open")
    assert isinstance(opened, HandMove) and opened.gripper > 0.02
    assert isinstance(body.moves[0], JointMove)  # the other hand is lifted clear of the floor first
    assert body.stowed
    assert report.error_m == pytest.approx(0.01) and report.stance_corrections == 0


def test_an_out_of_reach_spot_is_walked_up_to_first() -> None:
    body = FakeBody((IN_REACH[0] - 0.2, IN_REACH[1] + 0.1), seen_after=SPOT)
    report = place("red mug", 0.05, SPOT, 0.0, body)
    assert len(body.stances) == 1 and report.stance_corrections == 1
    assert (body.stances[0].x, body.stances[0].y) == pytest.approx(IN_REACH)


def test_an_object_held_in_the_left_hand_is_put_down_from_the_mirror_image_stance_with_the_left_arm() -> None:
    body = FakeBody((IN_REACH[0] - 0.2, IN_REACH[1] + 0.1), seen_after=SPOT)
    place("red mug", 0.05, SPOT, 0.0, body, hand="left")
    (stance,) = body.stances
    assert stance.hand == "left"
    assert (stance.x, stance.y) == pytest.approx((SPOT[0] - GRASP_OFFSET[0], SPOT[1] + GRASP_OFFSET[1]))
    assert body.hands == ["left"]
    other_arm_back = body.moves[0]
    assert isinstance(other_arm_back, JointMove)
    assert all(name.startswith("r_") for name in other_arm_back.positions)  # the right arm clears the floor
    with pytest.raises(PlaceFailed, match="unreachable"):  # from a right-handed stance it never reaches
        place("red mug", 0.05, SPOT, 0.0, StuckBody(IN_REACH, seen_after=SPOT), hand="left")


class StuckBody(FakeBody):
    """A robot that cannot walk: it stays where it stands."""

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        self.stances.append(stance)


def test_an_object_not_seen_where_it_was_let_go_is_a_failure_that_says_so() -> None:
    with pytest.raises(PlaceFailed, match="not found"):
        place("red mug", 0.05, SPOT, 0.0, FakeBody(IN_REACH, seen_after=None))
    fell_off = SPOT + np.array([0.0, 0.08, -0.25])
    with pytest.raises(PlaceFailed, match="did not stay where it was put"):
        place("red mug", 0.05, SPOT, 0.0, FakeBody(IN_REACH, seen_after=fell_off))


def test_a_toppled_object_fails_the_check_and_one_seen_a_little_low_is_standing() -> None:
    toppled = SPOT + np.array([0.0, 0.0, 0.0175])  # a mug on its side shows its base centre this much higher
    with pytest.raises(PlaceFailed, match="did not stay where it was put"):
        place("red mug", 0.05, SPOT, 0.0, FakeBody(IN_REACH, seen_after=toppled))
    seen_low = SPOT + np.array([0.02, 0.0, -0.013])  # the camera's error (seen once, the mug upright on the table)
    assert place("red mug", 0.05, SPOT, 0.0, FakeBody(IN_REACH, seen_after=seen_low)).error_m == pytest.approx(0.02)


def test_spots_in_reach_of_where_the_robot_stopped_lie_on_the_surface_nearest_the_middle_of_the_reach() -> None:
    # standing 21 cm in front of the near edge, facing the table: the middle of the reach is on it
    spots = spots_in_reach(TABLE, (-1.2, 0.29, math.pi / 2), [])
    assert spots[0] == pytest.approx([-1.2 + 0.11, 0.29 + 0.31, 0.2], abs=0.006)  # 31 cm ahead, 11 cm right
    # standing 4 cm further back: only the far part of the reach is on the table, at least EDGE_MARGIN_M in
    far = spots_in_reach(TABLE, (-1.2, 0.25, math.pi / 2), [])
    assert far and all(TABLE.contains(float(s[0]), float(s[1]), -EDGE_MARGIN_M) for s in far)
    ahead = [float(s[1]) - 0.25 for s in far]
    assert REACH_X[0] + REACH_MARGIN_M - 1e-9 <= min(ahead) and max(ahead) <= REACH_X[1] - REACH_MARGIN_M + 1e-9
    # what stands there already is kept clear of; facing away or too far, nothing is in reach
    taken = spots_in_reach(TABLE, (-1.2, 0.29, math.pi / 2), [(-1.09, 0.6)])
    assert all(math.dist(s[:2], (-1.09, 0.6)) >= SPACING_M for s in taken)
    assert spots_in_reach(TABLE, (-1.2, 0.29, -math.pi / 2), []) == []
    assert spots_in_reach(TABLE, (-1.2, 0.05, math.pi / 2), []) == []
    # for the left hand, the mirror image: 11 cm to the left
    left = spots_in_reach(TABLE, (-1.2, 0.29, math.pi / 2), [], hand="left")
    assert left[0] == pytest.approx([-1.2 - 0.11, 0.29 + 0.31, 0.2], abs=0.006)
