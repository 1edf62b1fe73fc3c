"""Gestures: the arm and head joint motions a behaviour shows people (wave, nod, shake the head, point).

Arm gestures are joint moves played by the arm motion the manipulation steps use (the joint arbiter gives it the
joints, then hands them back to standing); head gestures go through the head controller. Each blocks in simulated
time and gives up when the behaviour is paused or stopped, leaving the arm to be stowed by the runner.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from robot.behaviours.arm_room import WAVE_SWEEP, Sweep, occupied_cells, point_sweep, turn_for_room
from robot.control.head import DEFAULT_TILT
from robot.manipulation.arm_motion import JointMove, Move
from robot.model import humanoid_v1
from robot.perception.geometry import yaw_of
from robot.planning.executor import ExecutionContext, StepFailed
from robot.skills.body import BodyParts

GESTURES = ("wave", "nod", "shake_head", "point")
# The right arm held out to the side with the forearm up (hand about 30 cm above the shoulder), and the elbow's
# swing either side of that for a wave (rad).
WAVE_ARM = {"r_sho_pitch": 0.0, "r_sho_roll": 0.0, "r_el": -1.2}
WAVE_SWING_RAD = 0.35
WAVES = 3
# The right arm straight ahead, tilted down by the angle to what it points at (rad).
POINT_ARM = {"r_sho_roll": -1.2, "r_el": 0.0}
POINT_HOLD_S = 1.0
# Head gestures: amplitude (rad) and how many times either way.
NOD_TILT_RAD = 0.25
SHAKE_PAN_RAD = 0.45
HEAD_REPEATS = 2


def arm_down() -> dict[str, float]:
    stand = humanoid_v1.stand_posture()
    return {n: stand[n] for n in ("r_sho_pitch", "r_sho_roll", "r_el", "r_wrist")}


def wave_moves() -> list[Move]:
    moves: list[Move] = [JointMove(dict(WAVE_ARM), 1.0, "arm up to wave")]
    for _ in range(WAVES):
        moves.append(JointMove({"r_el": WAVE_ARM["r_el"] - WAVE_SWING_RAD}, 0.35, "wave out"))
        moves.append(JointMove({"r_el": WAVE_ARM["r_el"] + WAVE_SWING_RAD}, 0.35, "wave in"))
    moves.append(JointMove(arm_down(), 1.0, "arm down"))
    return moves


def point_moves(pitch_down_rad: float) -> list[Move]:
    """The arm raised forward to point `pitch_down_rad` below horizontal, held, then lowered."""
    pitch = math.pi / 2 - max(0.0, min(1.0, pitch_down_rad))
    raised = {**POINT_ARM, "r_sho_pitch": pitch}
    return [
        JointMove(raised, 1.2, "point"),
        JointMove(raised, POINT_HOLD_S, "hold the point"),
        JointMove(arm_down(), 1.2, "arm down"),
    ]


def play_arm(parts: BodyParts, ctx: ExecutionContext, moves: list[Move]) -> None:
    """Play joint moves on the arm, standing still; the joints go back to standing after (or on a stop)."""
    arm = parts.arm
    if arm.held is not None:
        raise StepFailed(f"holding the {arm.held}: the arm cannot gesture")
    while parts.legs.moving:
        ctx.wait_sim(0.02)
    motion = arm.take()
    motion.queue(*moves)
    try:
        while not motion.done.is_set():
            ctx.wait_sim(0.02)
            if parts.legs.fallen():
                raise StepFailed("fell while gesturing")
    finally:
        motion.stop()
    arm.release(None)


def play_head(parts: BodyParts, ctx: ExecutionContext, targets: list[tuple[float, float]]) -> None:
    head = parts.head
    try:
        for pan, tilt in targets:
            head.point(pan, tilt)
            waited = 0.0
            while not head.at_target and waited < 2.0:
                ctx.wait_sim(0.02)
                waited += 0.02
    finally:
        head.point(0.0, DEFAULT_TILT)


def nod_targets() -> list[tuple[float, float]]:
    return [(0.0, DEFAULT_TILT + sign * NOD_TILT_RAD) for _ in range(HEAD_REPEATS) for sign in (-1, 1)]


def shake_targets() -> list[tuple[float, float]]:
    return [(sign * SHAKE_PAN_RAD, DEFAULT_TILT) for _ in range(HEAD_REPEATS) for sign in (1, -1)]


class NoRoom(StepFailed):
    """Something on the map is within the arm's sweep wherever the robot may face: the arm stays down."""


def make_room(parts: BodyParts, sweep: Sweep, turn: Callable[[float], None] | None, what: str) -> str:
    """Clear floor on the lidar's map where the arm will sweep: turned in place to find it if `turn` is given;
    `NoRoom` when there is none. What was done, for the gesture's report ("" when nothing was needed)."""
    perception = parts.perception
    grid = perception.feed().map if perception is not None else None
    if grid is None:
        return ""  # no map (a robot without a lidar): nothing known to be in the way
    position, rotation = parts.localiser.map_trunk()
    pose = (float(position[0]), float(position[1]), yaw_of(rotation))
    if turn is None:
        angle = 0.0 if occupied_cells(grid, pose, sweep) == 0 else None
    else:
        angle = turn_for_room(grid, pose, sweep)
    if angle is None:
        raise NoRoom(f"no room to {what}: something on the map is within the arm's reach")
    if angle == 0.0:
        return ""
    assert turn is not None
    turn(angle)
    return f" (turned {math.degrees(angle):.0f} deg first, away from something within the arm's reach)"


def perform(
    name: str,
    parts: BodyParts,
    ctx: ExecutionContext,
    aim: Callable[[], float] | None = None,
    turn: Callable[[float], None] | None = None,
) -> str:
    """Play gesture `name`; `aim` (for "point") turns the robot to face the target and returns how far below the
    horizontal it is (rad); `turn` turns the robot in place (rad) to give a wave room."""
    if name == "wave":
        turned = make_room(parts, WAVE_SWEEP, turn, "wave")
        play_arm(parts, ctx, wave_moves())
        return "waved" + turned
    if name == "nod":
        play_head(parts, ctx, nod_targets())
        return "nodded"
    if name == "shake_head":
        play_head(parts, ctx, shake_targets())
        return "shook the head"
    if name == "point":
        if aim is None:
            raise StepFailed("pointing needs something to point at")
        pitch_down = aim()
        make_room(parts, point_sweep(pitch_down), None, "point")
        play_arm(parts, ctx, point_moves(pitch_down))
        return "pointed"
    raise StepFailed(f"unknown gesture {name!r} (known: {', '.join(GESTURES)})")
