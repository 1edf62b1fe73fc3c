"""Where to stand to pick an object up, whether it is in reach from here, and the arm moves that grasp it.

All measured in simulation with humanoid_v1's right hand (scratch trials, seeds 0-6): the OP3 arm cannot bring
its hand nearer than about 0.25 m in front of the feet at shoulder height, so the object goes 0.31 m ahead and
0.11 m to the right of the feet centre; the hand comes from 6 cm behind and 3 cm above and closes with the object
between the middles of the finger pads (the palm clears it).

The left hand does the mirror image of all of it (`for_hand`; the robot is left-right symmetric): a grasp falls to it
only where no stance for the right hand is free (world seed 4: a plant stands where the feet go for the apple).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robot.manipulation.arm_motion import HandMove, JointMove, Move
from robot.manipulation.reach_ik import trunk_height_for
from robot.model import humanoid_v1
from robot.model.world import Box

# The object in the feet frame when standing to grasp it with the right hand (m).
GRASP_OFFSET = (0.31, -0.11)
# With something close on the robot's left (a wall at the counter's end), it stands 5 cm further right: world seed 5
# has the mug 0.35 m from a wall, which leaves the usual stance 0.24 m from it, inside the navigator's margin.
CROWDED_LEFT_OFFSET = (0.31, -0.06)
# Room (m, from the feet centre) wanted on the robot's left at the stance; with less, it stands further right.
STANCE_LEFT_ROOM_M = 0.36
# What the arm reaches from a stance (feet frame, m): beyond this the stance is corrected first.
# (scratch trials: grasps at 0.27/0.35 ahead and -0.19/-0.03 to the side all lifted the mug 6 cm)
REACH_X = (0.27, 0.35)
REACH_Y = (-0.19, -0.03)
REACH_SURFACE_Z = (0.15, 0.32)
APPROACH_BACK_M = 0.06
APPROACH_UP_M = 0.03
# The hand's grasp point goes this far past the object's axis (m): the finger pads are centred 6 mm behind it and
# a grasp point on the axis left the object at the fingertips, squeezed out when the arm moved (the palm is 2 cm
# behind the pads: it does not touch a 35 mm mug).
PAST_AXIS_M = 0.006
LIFT_M = 0.05
# Finger opening (each finger, m) below which the gripper closed on nothing.
EMPTY_GRIP_M = 0.004


Hand = Literal["right", "left"]
HANDS: tuple[Hand, ...] = ("right", "left")  # in the order they are tried: the right hand's moves were tuned


@dataclass(frozen=True)
class Stance:
    """Where the feet stand (their centre, map frame), which way they face, and which hand grasps from there: the
    reach is measured from them."""

    x: float
    y: float
    yaw: float
    hand: Hand = "right"


def for_hand(moves: list[Move], hand: Hand) -> list[Move]:
    """The right hand's moves for `hand`: joint moves mirrored to the other arm; hand moves are targets in the feet
    frame already (the object's own position), the same for either hand."""
    if hand == "right":
        return list(moves)
    return [
        JointMove(humanoid_v1.mirror_arm_joints(m.positions), m.duration_s, m.label) if isinstance(m, JointMove) else m
        for m in moves
    ]


def _on_hand_side(offset: tuple[float, float], hand: Hand) -> tuple[float, float]:
    """An offset tuned for the right hand (feet frame), for `hand`: mirrored across the feet's centre line."""
    return offset if hand == "right" else (offset[0], -offset[1])


def _sideways_for_hand(extent: tuple[float, float], hand: Hand) -> tuple[float, float]:
    """A side-to-side extent tuned for the right hand (feet frame, low to high), for `hand`: mirrored."""
    return extent if hand == "right" else (-extent[1], -extent[0])


def grasp_offset(hand: Hand) -> tuple[float, float]:
    """Where the object goes from the feet at `hand`'s usual stance (GRASP_OFFSET, mirrored for the left hand)."""
    return _on_hand_side(GRASP_OFFSET, hand)


def trunk_pose_at(stance: Stance, trunk_ahead: np.ndarray) -> tuple[float, float, float]:
    """The trunk's pose (what walking steers) with the feet at `stance`, the trunk `trunk_ahead` (x, y; feet frame)
    from the feet's centre: steering the trunk onto the stance itself left the mug 3.5 cm beyond the reach window
    with the arms held back (the trunk stands 3.5 cm ahead of the feet to balance them)."""
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    dx, dy = float(trunk_ahead[0]), float(trunk_ahead[1])
    return stance.x + c * dx - s * dy, stance.y + s * dx + c * dy, stance.yaw


# Where the robot's feet, shins and hands at rest are, around a stance (stance frame, m: x ahead, y to the left):
# the hands held back reach 0.2 m behind the trunk and 0.15 m out to the sides. Nothing on the map may be there (the
# last steps onto a stance are walked without the map: at world seed 0 the robot pushed a chair for 30 s trying to
# stand where it stood).
STANCE_FOOTPRINT_X = (-0.2, 0.08)
STANCE_FOOTPRINT_Y = (-0.18, 0.18)
# Where the right arm swings out to the side as it rises (stance frame, m): the hand 0.35 m out from the feet centre.
ARM_SWEEP_X = (-0.1, 0.06)
ARM_SWEEP_Y = (-0.38, -0.14)
# ...and the open fingers beyond the hand: by MuJoCo's geometry 0.43 m out, 0.37 m up. At world seed 0 the apple's
# stance at the counter's end has the wall 1.3 cm beyond them; a walk that ended 5.5 cm nearer the wall (a busy
# machine) struck it with a finger and the grasp closed on nothing. Where the robot stands at the grasp, the swing
# needs room out to the fingertips (both edges on the 4 cm grid, for either hand).
ARM_SWEEP_FINGERTIPS_Y = (-0.44, -0.12)
# Turns (rad) from a place's approach to try when something stands on the stance: two small, two larger.
TURNED_FACINGS_RAD = (0.35, -0.35, 0.7, -0.7)
# How far in from a surface's edge an object can be grasped from that side: the toes stay out of the surface.
OBJECT_FROM_EDGE_MAX_M = GRASP_OFFSET[0] - STANCE_FOOTPRINT_X[1]


def grasp_stance(
    object_xy: tuple[float, float],
    facing_yaw: float,
    blocked: Callable[[float, float], bool] | None = None,
    hand: Hand = "right",
) -> Stance:
    """The pose to stand at, facing `facing_yaw`, to have the object at GRASP_OFFSET from the feet (mirrored for the
    left hand). Given the map (`blocked`: is this point taken?), a stance with something close on the free arm's
    side (a wall at the counter's end) moves away from it, with the object at CROWDED_LEFT_OFFSET; one where
    something stands (a chair by the counter) moves to the nearest other place in the reach window that is free
    (the caller checks `stance_taken`: none may be)."""
    stance = _stance_with_object_at(object_xy, facing_yaw, grasp_offset(hand), hand)
    if blocked is None:
        return stance
    # the free arm's side: the left of a right-handed stance, the left of the opposite heading for a left-handed one
    free_side_yaw = stance.yaw if hand == "right" else stance.yaw + math.pi
    if room_on_left(stance.x, stance.y, free_side_yaw, blocked) < STANCE_LEFT_ROOM_M:
        stance = _stance_with_object_at(object_xy, facing_yaw, _on_hand_side(CROWDED_LEFT_OFFSET, hand), hand)
    if not stance_taken(stance, blocked):
        return stance
    for offset in SHIFTED_OFFSETS:
        shifted = _stance_with_object_at(object_xy, facing_yaw, _on_hand_side(offset, hand), hand)
        if not stance_taken(shifted, blocked):
            return shifted
    return stance


def stance_facings(approach_yaw: float, surface: Box | None, object_xy: tuple[float, float]) -> list[float]:
    """The ways to face a surface to grasp an object on it, in the order to try them: the place's approach, turned
    a little either way, squarely from another side of the surface the object is near enough to reach across,
    then turned further. At world seed 0 a chair
    stood against the counter where the feet go for the apple, and the fetch gave up ("no room to stand")."""
    facings = [approach_yaw, *(approach_yaw + turn for turn in TURNED_FACINGS_RAD[:2])]
    if surface is not None:
        cx, cy, hx, hy = surface.x, surface.y, surface.half_x, surface.half_y
        x, y = object_xy
        sides = (  # (the side's distance from the object, the yaw that faces the surface from it)
            (x - (cx - hx), 0.0),
            ((cx + hx) - x, math.pi),
            (y - (cy - hy), math.pi / 2),
            ((cy + hy) - y, -math.pi / 2),
        )
        for depth, yaw in sorted(sides):
            if depth <= OBJECT_FROM_EDGE_MAX_M and not same_facing(yaw, approach_yaw):
                facings.append(yaw)
    facings += [approach_yaw + turn for turn in TURNED_FACINGS_RAD[2:]]
    return facings


# Two facings closer than this (rad) are one: the usual stance's, not another side's or a turned one.
SAME_FACING_RAD = 0.1


def same_facing(a: float, b: float) -> bool:
    """Whether two yaws face the same way (within SAME_FACING_RAD)."""
    return abs(math.remainder(a - b, math.tau)) < SAME_FACING_RAD


def grasp_stance_facing_any(
    object_xy: tuple[float, float],
    facings: list[float],
    blocked: Callable[[float, float], bool] | None,
    hands: tuple[Hand, ...] = HANDS,
) -> Stance:
    """The first stance in `facings` (see `stance_facings`) where nothing on the map stands (`grasp_stance` for
    each; the others also with room for the arm to swing out sideways), for each of `hands` in turn (the right
    hand, then the left); the first one's when all are taken (the caller checks `stance_taken`). A turned stance
    whose only fault is the sideways swing is not taken although the arm can come out in front there: on worlds
    never tuned on (seeds 110-399) the walk into such cramped stances fell in 2 of 6. At world seed 4 the apple's
    stances for the right hand are all taken (a plant where the feet go, a box in the turned ones' swing); the left
    hand's usual one is free."""
    first = grasp_stance(object_xy, facings[0], blocked, hands[0])
    if blocked is None or not stance_taken(first, blocked):
        return first
    for hand in hands:
        for k, yaw in enumerate(facings):
            if hand == hands[0] and k == 0:
                continue
            stance = grasp_stance(object_xy, yaw, blocked, hand)
            if not stance_taken(stance, blocked) and (k == 0 or not arm_sweep_taken(stance, blocked)):
                return stance
    return first


def arm_sweep_taken(stance: Stance, blocked: Callable[[float, float], bool], to_fingertips: bool = False) -> bool:
    """Something on the map where the stance's grasping arm swings out sideways before reaching forward
    (`arm_out_moves`), checked every 4 cm: out to the hand, or `to_fingertips` (where the robot stands at the
    grasp: ARM_SWEEP_FINGERTIPS_Y). A stance turned beside a box at world seed 4 swept the hand into it and the
    grasp closed on nothing: a turned stance needs this clear. At the usual stance the arm comes out in front
    instead (`arm_out_moves`; world seed 0's bottle has a chair there)."""
    sideways = ARM_SWEEP_FINGERTIPS_Y if to_fingertips else ARM_SWEEP_Y
    return _area_taken(stance, ARM_SWEEP_X, _sideways_for_hand(sideways, stance.hand), blocked)


# Other places of the object in the feet frame, inside the reach window with REACH_MARGIN_M to spare, nearest the
# usual one first: where to stand instead when something stands on the usual stance.
SHIFTED_OFFSETS = tuple(
    sorted(
        ((x, y) for x in (0.29, 0.31, 0.33) for y in (-0.17, -0.14, -0.11, -0.08, -0.05)),
        key=lambda o: math.dist(o, GRASP_OFFSET),
    )
)


def no_room_to_stand(what: str, stance: Stance) -> str:
    return (
        f"no room to stand where the hand reaches the {what}: something on the map stands at "
        f"({stance.x:.2f}, {stance.y:.2f}), where the robot's feet would be"
    )


# Where the other arm's hand goes behind the back as it swings back for the crouch (LEFT_ARM_BACK; stance frame, m):
# by forward kinematics 0.255 m behind the feet centre, on their middle line, 0.18-0.22 m up, past the footprint.
# At world seed 39 a chair stood 0.205 m behind the usual stance, outside the footprint: the swinging hand pushed
# it until the shoulder servo overloaded and the robot stopped.
OTHER_HAND_BACK_X = (-0.29, -0.2)
OTHER_HAND_BACK_Y = (-0.06, 0.06)


def stance_taken(stance: Stance, blocked: Callable[[float, float], bool]) -> bool:
    """Something on the map where the robot would stand at `stance` (checked every 4 cm over its footprint), or
    where the other arm's hand swings behind its back."""
    return _area_taken(stance, STANCE_FOOTPRINT_X, STANCE_FOOTPRINT_Y, blocked) or _area_taken(
        stance, OTHER_HAND_BACK_X, OTHER_HAND_BACK_Y, blocked
    )


def _area_taken(
    stance: Stance,
    ahead_m: tuple[float, float],
    left_m: tuple[float, float],
    blocked: Callable[[float, float], bool],
) -> bool:
    """Something on the map in the rectangle `ahead_m` x `left_m` of the stance frame (every 4 cm)."""
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    for ahead in np.arange(ahead_m[0], ahead_m[1] + 1e-9, 0.04):
        for left in np.arange(left_m[0], left_m[1] + 1e-9, 0.04):
            if blocked(stance.x + c * ahead - s * left, stance.y + s * ahead + c * left):
                return True
    return False


def _stance_with_object_at(
    object_xy: tuple[float, float], yaw: float, offset: tuple[float, float], hand: Hand = "right"
) -> Stance:
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = offset
    return Stance(object_xy[0] - (c * dx - s * dy), object_xy[1] - (s * dx + c * dy), yaw, hand)


def other_hand(hand: Hand) -> Hand:
    return "left" if hand == "right" else "right"


def reach_window_y(hand: Hand) -> tuple[float, float]:
    """The side-to-side extent of `hand`'s reach (feet frame, m; REACH_Y mirrored for the left hand)."""
    return _sideways_for_hand(REACH_Y, hand)


def reach_problem(object_in_feet: np.ndarray, hand: Hand = "right") -> str | None:
    """Why the object (feet frame) is out of `hand`'s reach from here, or None if it is within reach."""
    x, y, z = (float(v) for v in object_in_feet)
    low_y, high_y = reach_window_y(hand)
    if not REACH_X[0] <= x <= REACH_X[1]:
        return f"{x:.2f} m ahead (reach {REACH_X[0]:.2f}-{REACH_X[1]:.2f} m)"
    if not low_y <= y <= high_y:
        return f"{y:+.2f} m to the side (reach {low_y:+.2f} to {high_y:+.2f} m)"
    if not REACH_SURFACE_Z[0] <= z <= REACH_SURFACE_Z[1]:
        return f"on a surface {z:.2f} m high (reach {REACH_SURFACE_Z[0]:.2f}-{REACH_SURFACE_Z[1]:.2f} m)"
    return None


# Where a walk to a work pose may come to rest: with the object at least this far inside the reach window (m), so
# that the fresh sighting at the surface, a cm or so off the remembered position, still finds it in reach.
REACH_MARGIN_M = 0.015


def comfortably_in_reach(object_in_feet: np.ndarray, margin: float = REACH_MARGIN_M, hand: Hand = "right") -> bool:
    """Whether the object (feet frame) is in `hand`'s reach with `margin` to spare on every side."""
    x, y, z = (float(v) for v in object_in_feet)
    low_y, high_y = reach_window_y(hand)
    return (
        REACH_X[0] + margin <= x <= REACH_X[1] - margin
        and low_y + margin <= y <= high_y - margin
        and REACH_SURFACE_Z[0] <= z <= REACH_SURFACE_Z[1]
    )


def grasp_height(object_height: float, round_object: bool = False) -> float:
    """Where on the object the fingers close, above its base (m): a little above the middle, under the rim; a round
    object at its widest. The flat pads squeeze a ball out towards whichever side of its middle they close on:
    an apple gripped 1 cm above it (a retried pick closed high) worked its way down between the pads as the robot
    walked and fell out."""
    if round_object:
        return object_height / 2.0
    return min(0.6 * object_height, object_height - 0.015)


RIGHT_ARM_OUT = {"r_sho_roll": 0.0, "r_sho_pitch": 0.0, "r_el": 0.0, "r_wrist": 0.0}
# The left arm swung further back from its rest, the elbow still bent: its hand clear of the floor in the crouch
# (8.6 cm at the deepest), within the body's width (nothing beside the robot is touched; 0.13 m out at most, the arm at
# rest 0.15 m), its forearm 2.5 cm from the trunk (the reaching solver holds it still) and its weight behind the trunk,
# against the reaching right arm. Teleported scratch grasps on a 5 x 5 grid of the reach window (0.27-0.35 m ahead,
# -0.19 to -0.03 m to the side), with the arm straight, lifted the mug at every point, also beside the wall on world
# seeds 4, 5 and 10; with the left arm out sideways, the hand pushed the wall and the robot over; with it forward, the
# grasps 0.33 m ahead failed (the robot tipped, the mug slipped). Straight, it was 0.19 m out, wider than at rest.
LEFT_ARM_BACK = {"l_sho_pitch": 1.0, "l_sho_roll": 1.3, "l_el": -0.8}


def room_on_left(
    x: float, y: float, yaw: float, blocked: Callable[[float, float], bool], out_to_m: float = STANCE_LEFT_ROOM_M
) -> float:
    """How far to the left of a robot standing at (x, y) facing `yaw` the map is free, up to `out_to_m` (m, checked
    every 2 cm from 0.1 m out)."""
    for r in np.arange(0.10, out_to_m + 1e-9, 0.02):
        if blocked(x - math.sin(yaw) * r, y + math.cos(yaw) * r):
            return float(r)
    return out_to_m


# The right hand in front at shoulder height, the arm flat and folded: where both ways out end.
RIGHT_ARM_IN_FRONT = {"r_sho_pitch": 1.57, "r_sho_roll": -0.8, "r_el": 1.8, "r_wrist": -0.9}
# The way out in front, for when something stands where the arm swings out sideways: the hand comes forward low
# beside the hip, the arm folded, then rises in front of the chest and over the surface's edge. Searched with
# MuJoCo's geometry (standing posture, stances 3 cm and 0.1 rad off) on world seed 4's turned stances beside a box
# and on the usual stances of seven worlds. On 14 usual stances with something in the sideways swing (worlds 0 and
# 4, and 12 of seeds 110-399 never searched on) it keeps 1.7 cm from everything (1 cm into the counter's edge at
# worst with the robot 3 cm nearer), where the sideways swing goes 1.5-12 cm into a chair, plant or box.
ARM_FORWARD_WAYPOINTS = (
    {"r_sho_pitch": 0.08, "r_sho_roll": -0.87, "r_el": 1.17, "r_wrist": -0.65},
    {"r_sho_pitch": 0.83, "r_sho_roll": -0.95, "r_el": 1.98, "r_wrist": 0.2},
)


def arm_out_moves(sideways_clear: bool = True, hand: Hand = "right") -> list[Move]:
    """From the arms at rest to the right hand in front at shoulder height, clear of what stands on the surface:
    raise the arm sideways (opening the gripper out there), turn it flat, fold the elbow, swing it forward (a
    straight hand path would sweep through the counter). The left arm swings back for the crouch (LEFT_ARM_BACK).
    Where something stands in the sideways swing (`arm_sweep_taken`; not `sideways_clear`), the arm comes out in
    front instead (ARM_FORWARD_WAYPOINTS): at world seed 0 a chair stands there beside the bottle's stance."""
    first = {**LEFT_ARM_BACK, "r_grip": humanoid_v1.FINGER_TRAVEL}
    if not sideways_clear:
        low, high = ARM_FORWARD_WAYPOINTS
        return for_hand(
            [
                JointMove({**low, **first}, 0.8, "forward low"),
                JointMove(high, 0.8, "raise in front"),
                JointMove(RIGHT_ARM_IN_FRONT, 0.8, "over the surface"),
            ],
            hand,
        )
    return for_hand(
        [
            JointMove({**RIGHT_ARM_OUT, **first}, 0.8, "raise sideways"),
            JointMove({"r_sho_pitch": RIGHT_ARM_IN_FRONT["r_sho_pitch"]}, 0.6, "turn flat"),
            JointMove({n: RIGHT_ARM_IN_FRONT[n] for n in ("r_el", "r_wrist")}, 0.6, "fold"),
            JointMove({"r_sho_roll": RIGHT_ARM_IN_FRONT["r_sho_roll"]}, 0.8, "swing forward"),
        ],
        hand,
    )


def grasp_moves(
    object_in_feet: np.ndarray, object_height: float, round_object: bool = False
) -> tuple[list[Move], np.ndarray]:
    """Pre-grasp, approach and close on an object whose base centre is at `object_in_feet`; returns the moves and
    the hand's grasp point."""
    grasp = np.asarray(object_in_feet, dtype=float) + np.array(
        [PAST_AXIS_M, 0.0, grasp_height(object_height, round_object)]
    )
    height = trunk_height_for(float(grasp[2]))
    open_ = humanoid_v1.FINGER_TRAVEL
    pre = grasp + np.array([-APPROACH_BACK_M, 0.0, APPROACH_UP_M])
    moves: list[Move] = [
        HandMove(tuple(pre), 1.5, open_, height, label="pre-grasp"),
        HandMove(tuple(grasp), 1.5, open_, height, label="approach"),
        HandMove(tuple(grasp), 1.0, 0.0, height, label="close"),
    ]
    return moves, grasp


def lift_moves(grasp: np.ndarray, object_height: float) -> list[Move]:
    lifted = np.asarray(grasp) + np.array([0.0, 0.0, LIFT_M])
    return [HandMove(tuple(lifted), 1.2, 0.0, trunk_height_for(float(grasp[2])), label="lift")]


# The arm held in for walking: folded, flat at shoulder height, the hand 0.25 m ahead of the feet and the gripper's
# closing axis across the body (the object upright). Forward kinematics at the standing posture.
CARRY_ARM = {"r_sho_pitch": 1.5, "r_sho_roll": -0.5, "r_el": 2.0, "r_wrist": -1.0}
CARRY_HAND_AHEAD_M = 0.25


# A hand holds something when its fingers stand open by more than an empty grip while commanded this much tighter
# (a position servo closing on an object stalls on it; in free air the fingers reach their target).
GRIP_SQUEEZE_M = 0.003


def grasping(commanded_grip_m: float, measured_grip_m: float) -> bool:
    """Whether the hand holds something, by its fingers: how a stopped pick or place knows whether it still has the
    object (before the lift, after the release or anywhere between)."""
    return measured_grip_m >= EMPTY_GRIP_M and commanded_grip_m < measured_grip_m - GRIP_SQUEEZE_M


def carry_moves(hand: Hand = "right") -> list[Move]:
    """From holding the object up where it was grasped to carrying it close to the body (less to sway when
    walking, nothing sticking out to sweep into furniture when turning); the other arm goes back to rest."""
    stand = humanoid_v1.stand_posture()
    left_arm_at_rest = {n: stand[n] for n in LEFT_ARM_BACK}
    return for_hand([JointMove({**CARRY_ARM, **left_arm_at_rest}, 1.2, "carry")], hand)


PLACE_ABOVE_M = 0.04  # the object is carried over its spot this high above where it will stand, then lowered
SET_DOWN_ABOVE_M = 0.004  # released this far above the surface: the fingers do not scrape it


def place_moves(
    spot_in_feet: np.ndarray, object_height: float, round_object: bool = False, hand: Hand = "right"
) -> tuple[list[Move], np.ndarray]:
    """Carry the held object over the spot (feet frame, on the surface), lower it, let go and back away; returns the
    moves and the hand's release point."""
    release = np.asarray(spot_in_feet, dtype=float) + np.array(
        [PAST_AXIS_M, 0.0, grasp_height(object_height, round_object) + SET_DOWN_ABOVE_M]
    )
    height = trunk_height_for(float(release[2]))
    above = release + np.array([0.0, 0.0, PLACE_ABOVE_M])
    moves: list[Move] = [
        JointMove(LEFT_ARM_BACK, 0.8, "other arm back"),  # clear of the floor in the crouch
        HandMove(tuple(above), 1.5, 0.0, height, label="over the spot"),
        HandMove(tuple(release), 1.2, 0.0, height, label="set down"),
        *release_moves(release),
    ]
    return for_hand(moves, hand), release


# Where the hand ends after letting go, from the release point (m): behind and above the object. Further (it was
# 0.10 and 0.10) is out of reach: the hand came near the shoulder and the solver dropped the trunk instead (knees to
# 1.7 rad; the robot pitched 9 deg and fell as it stood up, world seeds 0 and 29). Replayed through the solver, this
# point is reached from every surface height in reach without the trunk sinking.
CLEAR_BACK_M = 0.06
CLEAR_UP_M = 0.06


def release_moves(grasp: np.ndarray) -> list[Move]:
    """Open, back away and rise clear (after a failed grasp, or after placing), the trunk rising with the hand;
    nothing is held, so the hand's height is not corrected for sag."""
    g = np.asarray(grasp)
    open_ = humanoid_v1.FINGER_TRAVEL
    back = g + np.array([-APPROACH_BACK_M, 0.0, APPROACH_UP_M])
    clear = g + np.array([-CLEAR_BACK_M, 0.0, CLEAR_UP_M])
    return [
        HandMove(tuple(g), 0.6, open_, trunk_height_for(float(g[2])), label="open"),
        HandMove(tuple(back), 1.0, open_, trunk_height_for(float(back[2])), correct_sag=False, label="back away"),
        HandMove(tuple(clear), 1.0, 0.0, trunk_height_for(float(clear[2])), correct_sag=False, label="clear"),
    ]
