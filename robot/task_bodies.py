"""The worker's body as plan steps use it: the head and legs for the object search (`TaskBody`), the legs and the
map for navigation (`NavBodyOfWorker`), the arm for picking and placing (`ArmBody`). Each call blocks in simulated
time and gives up when the plan is cancelled; the procedures they serve (search, navigator, pick, place) know
nothing of the worker.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from robot.control.head import DEFAULT_TILT
from robot.control.locomotion import Velocity, clip_velocity
from robot.interface import DetectedObject
from robot.manipulation.arm_motion import JointMove, Move
from robot.manipulation.grasp_plan import (
    CARRY_HAND_AHEAD_M,
    Stance,
    carry_moves,
    comfortably_in_reach,
    grasp_stance,
)
from robot.manipulation.pick import PickFailed
from robot.model import humanoid_v1
from robot.model.world import WorldLayout
from robot.navigation.costmap import Costmap
from robot.navigation.navigator import NavigationFailed
from robot.perception.geometry import yaw_of
from robot.planning.executor import ExecutionContext, StepFailed

if TYPE_CHECKING:
    from robot.worker import RobotWorker

_HEAD_PAN = humanoid_v1.JOINT_NAMES.index("head_pan")
_HEAD_TILT = humanoid_v1.JOINT_NAMES.index("head_tilt")
# Turning in place for a task (looking for an object, facing a point).
TURN_RATE_RAD_S = 0.5
TURN_TOLERANCE_RAD = 0.12
# After the head reaches its target, the image is steady after this long (s).
HEAD_SETTLE_S = 0.15


class TaskBody:
    """The robot's head and legs as a plan step uses them (the object search's `SearchBody`): each call blocks in
    simulated time and gives up when the plan is cancelled."""

    def __init__(self, worker: RobotWorker, ctx: ExecutionContext) -> None:
        self._worker = worker
        self._ctx = ctx

    def point_head(self, pan: float, tilt: float) -> None:
        worker = self._worker
        worker._head.point(pan, tilt)
        while not worker._head.at_target:
            self._ctx.wait_sim(0.02)
        self._ctx.wait_sim(HEAD_SETTLE_S)

    def look_at(self, target: tuple[float, float, float]) -> bool:
        position, rotation = self._worker._map_trunk()
        pan, tilt, reachable = self._worker._head.angles_to_look_at(position, rotation, np.asarray(target))
        if reachable:
            self.point_head(pan, tilt)
        return reachable

    def face(self, target: tuple[float, float, float]) -> None:
        position, rotation = self._worker._map_trunk()
        heading = math.atan2(target[1] - position[1], target[0] - position[0])
        self.turn_in_place(_wrap(heading - yaw_of(rotation)))

    def turn_in_place(self, angle: float) -> None:
        worker = self._worker
        worker._head.point(0.0, worker._head.target[1])
        turned, last = 0.0, yaw_of(worker._map_trunk()[1])
        try:
            for rate in (TURN_RATE_RAD_S, TURN_RATE_RAD_S / 2):  # a second, slower turn takes up the overshoot
                remaining = angle - turned
                if abs(remaining) < TURN_TOLERANCE_RAD:
                    break
                direction = math.copysign(1.0, remaining)
                worker._set_task_velocity(Velocity(0.0, 0.0, direction * rate))
                # a turn that takes three times as long as it should is blocked (an arm against furniture)
                deadline = worker._sim_time + 3.0 * abs(remaining) / rate + 3.0
                # stop early by about what the two stopping steps still turn
                while direction * (angle - turned) > rate * 0.3:
                    if worker._sim_time > deadline:
                        raise StepFailed(f"could not turn in place: turned {math.degrees(turned):.0f} of "
                                         f"{math.degrees(angle):.0f} deg (blocked?)")  # fmt: skip
                    self._ctx.wait_sim(0.02)
                    yaw = yaw_of(worker._map_trunk()[1])
                    turned += _wrap(yaw - last)
                    last = yaw
                worker._set_task_velocity(Velocity())
                while worker._loco.moving:
                    self._ctx.wait_sim(0.02)
                yaw = yaw_of(worker._map_trunk()[1])
                turned += _wrap(yaw - last)
                last = yaw
        finally:
            worker._set_task_velocity(Velocity())

    def fresh_detections(self) -> tuple[DetectedObject, ...]:
        perception = self._worker._perception
        assert perception is not None
        return perception.detections_after(self._worker._sim_time)


class NavBodyOfWorker:
    """The legs and the map as navigation uses them (the navigator's `NavBody`), in simulated time."""

    def __init__(self, worker: RobotWorker, ctx: ExecutionContext) -> None:
        self._worker = worker
        self._ctx = ctx
        self._scans = -1  # the map the costmaps below were grown from
        self._costmaps: dict[float, Costmap] = {}  # by inflation: navigation asks for a few each scan

    def pose(self) -> tuple[float, float, float]:
        position, rotation = self._worker._map_trunk()
        return float(position[0]), float(position[1]), yaw_of(rotation)

    def costmap(self, inflate_m: float) -> Costmap | None:
        perception = self._worker._perception
        grid = perception.feed().map if perception is not None else None
        if grid is None:
            return None
        if grid.scans != self._scans:
            self._scans, self._costmaps = grid.scans, {}
        if inflate_m not in self._costmaps:
            self._costmaps[inflate_m] = Costmap.from_map(grid, inflate_m)
        return self._costmaps[inflate_m]

    def drive(self, vx: float, vy: float, yaw_rate: float) -> None:
        velocity = clip_velocity(Velocity(vx, vy, yaw_rate), self._worker._loco.velocity.limits)
        self._worker._set_task_velocity(velocity)

    def halt_here(self) -> None:
        worker = self._worker
        worker._set_task_velocity(Velocity())
        with worker._lock:
            worker._stop_promptly = True

    def wait(self, seconds: float) -> None:
        self._ctx.wait_sim(seconds)

    def walking(self) -> bool:
        return self._worker._loco.moving

    def fallen(self) -> bool:
        with self._worker._lock:
            return self._worker._fallen


class ArmBody:
    """The robot as picking uses it (the pick procedure's `PickBody`), in simulated time."""

    def __init__(self, worker: RobotWorker, ctx: ExecutionContext) -> None:
        self._worker = worker
        self._ctx = ctx
        self._task = TaskBody(worker, ctx)

    def locate(self, name: str, near: np.ndarray | None = None) -> np.ndarray | None:
        worker = self._worker
        assert worker._perception is not None
        if near is None:
            remembered = worker._perception.memory.get(name)
            if remembered is None:
                return None
            near = np.asarray(remembered.position)
        self._task.look_at(near)
        deadline = worker._sim_time + LOCATE_TIMEOUT_S
        while worker._sim_time < deadline:
            for detection in self._task.fresh_detections():
                if detection.label == name:
                    return np.array(detection.position, dtype=float)
            self._ctx.wait_sim(0.05)
        return None

    def to_feet(self, point_in_map: np.ndarray) -> np.ndarray:
        worker = self._worker
        position, rotation = worker._map_trunk()
        in_trunk = rotation.T @ (np.asarray(point_in_map, dtype=float) - position)
        trunk = worker._arm_motion().trunk_in_feet(worker._measured.joint_positions)
        return trunk[:3, :3] @ in_trunk + trunk[:3, 3]

    def comfortably_reaches(self, point_in_map: np.ndarray) -> bool:
        """Whether the right hand reaches the map point from where the robot stands, with a margin to spare."""
        return comfortably_in_reach(self.to_feet(point_in_map))

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        worker = self._worker
        good_stop = None if reach is None else (lambda: self.comfortably_reaches(reach))
        worker._head.point(0.0, DEFAULT_TILT)
        back = (stance.x - STAGING_BACK_M * math.cos(stance.yaw), stance.y - STAGING_BACK_M * math.sin(stance.yaw))
        navigator = worker._navigator(self._ctx)
        x, y, _ = NavBodyOfWorker(worker, self._ctx).pose()
        try:
            if math.dist((x, y), (stance.x, stance.y)) < STEP_TO_M:  # the reach window is +-4 cm: settle tightly
                navigator.step_to((stance.x, stance.y, stance.yaw), STANCE_SETTLE_M, good_stop)
            else:
                navigator.go(back, (stance.x, stance.y, stance.yaw), good_stop)
        except NavigationFailed as exc:
            raise PickFailed(str(exc)) from exc
        finally:
            worker._set_task_velocity(Velocity())
            worker._set_navigation(None)

    def stance_for(self, point_in_map: np.ndarray) -> Stance:
        x, y = float(point_in_map[0]), float(point_in_map[1])
        facing = next((p.approach[2] for p in self._worker.layout.places
                       if p.surface is not None and p.surface.contains(x, y)), None)  # fmt: skip
        if facing is None:
            position, _ = self._worker._map_trunk()
            facing = math.atan2(y - position[1], x - position[0])
        return grasp_stance((x, y), facing, self._worker._map_blocked())

    def arm(self, moves: list[Move]) -> None:
        worker = self._worker
        if not worker._arm_active:
            # a walk that has just ended may still be moving to the standing posture: reaching from the posture half
            # way (knees deep as when carrying) made the first hand move snap the legs straight and tip the robot
            self._wait_standing()
        arm = worker._take_arm()
        arm.queue(*moves)
        try:
            while not arm.done.is_set():
                self._ctx.wait_sim(0.02)
                with worker._lock:
                    if worker._fallen:
                        raise PickFailed("fell while reaching")
        except BaseException:
            arm.stop()
            raise

    def grip_opening(self) -> float:
        return float(self._worker._measured.joint_positions[humanoid_v1.JOINT_NAMES.index("r_grip")])

    def stand_holding(self) -> None:
        worker = self._worker
        self.arm(_standing_up_with(carry_moves(), worker._default_stand))
        worker._release_arm(worker._arm_motion().targets)
        self._wait_standing()

    def stow_arm(self, finish_in_background: bool = False) -> None:
        worker = self._worker
        first, *rest = _standing_up_with(_arm_back_moves(), worker._default_stand)
        if finish_in_background:
            # the hand is out of the camera's view once swung back: the rest (1.6 s) goes on while the next steps run
            self.arm([first])
            worker._finish_arm_in_background(rest)
            return
        self.arm([first, *rest])
        worker._release_arm(None)
        self._wait_standing()

    def _wait_standing(self) -> None:
        worker = self._worker
        while not worker._posture.settled:
            self._ctx.wait_sim(0.02)


LOCATE_TIMEOUT_S = 2.0
STAGING_BACK_M = 0.12
CARRY_CLEARANCE_M = 0.02  # between the carried object and a surface's edge, before turning away from it
MIN_STEP_BACK_M = 0.04
STANCE_SETTLE_M = 0.02
STEP_TO_M = 0.6  # nearer than this, the stance is corrected by a straight walk
STAND_UP_S = 1.5


def carry_back_away_m(layout: WorldLayout, pose: tuple[float, float, float]) -> float:
    """How far a robot carrying something at `pose` must walk back before it turns away: the object, held out
    ahead, would otherwise sweep along the surface in front of it (0 when it is clear already)."""
    back = CARRY_HAND_AHEAD_M + CARRY_CLEARANCE_M - _surface_ahead_m(layout, *pose)
    return back if back >= MIN_STEP_BACK_M else 0.0


def _surface_ahead_m(layout: WorldLayout, x: float, y: float, yaw: float) -> float:
    """How far ahead of (x, y), looking along `yaw`, the nearest raised surface begins (inf if none)."""
    surfaces = [p.surface for p in layout.places if p.surface is not None and p.surface.height >= 0.05]
    return min((box.distance_along(x, y, yaw) for box in surfaces), default=math.inf)


def _legs_to(targets: np.ndarray, duration_s: float) -> JointMove:
    names = humanoid_v1.JOINT_NAMES
    return JointMove({n: float(targets[names.index(n)]) for n in humanoid_v1.LEG_JOINTS}, duration_s, "stand up")


def _standing_up_with(moves: list[Move], stand: np.ndarray) -> list[Move]:
    """The legs back to the standing posture while the first (joint) arm move plays: one move, not two in a row
    (1.2-1.5 s saved each time the robot stands up from a reach)."""
    first, *rest = moves
    if not isinstance(first, JointMove):
        raise TypeError("standing up goes with a joint move: a hand move would have the solver move the legs")
    legs = _legs_to(stand, STAND_UP_S)
    both = JointMove({**legs.positions, **first.positions}, max(STAND_UP_S, first.duration_s),
                     f"stand up, {first.label}")  # fmt: skip
    return [both, *rest]


SWING_BACK = {"r_sho_pitch": 1.57, "r_sho_roll": 0.0, "r_el": 1.8, "r_wrist": -0.9}


def _arm_back_moves() -> list[Move]:
    """The arm-out moves in reverse, ending in the standing arm posture with the gripper closed."""
    stand = humanoid_v1.stand_posture()
    return [
        JointMove({**SWING_BACK, "r_grip": 0.0}, 1.2, "swing back"),
        JointMove({"r_el": 0.0, "r_wrist": 0.0, "r_sho_pitch": 0.0}, 0.8, "unfold upright"),
        JointMove({n: stand[n] for n in ("r_sho_roll", "l_sho_pitch", "l_sho_roll", "l_el")}, 0.8, "arms down"),
    ]


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))
