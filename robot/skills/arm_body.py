"""The robot as picking and placing use it (the pick and place procedures' `PickBody` and `PlaceBody`): find the
object with a fresh look, walk to a stance, play arm moves, stand up holding it or stow the arm. Each call blocks
in simulated time and gives up when the plan is cancelled."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from robot.control.head import DEFAULT_TILT
from robot.manipulation.arm_motion import Move
from robot.manipulation.grasp_plan import (
    Hand,
    Stance,
    arm_sweep_taken,
    carry_moves,
    comfortably_in_reach,
    grasp_stance,
    grasp_stance_facing_any,
    no_room_to_stand,
    other_hand,
    stance_facings,
    stance_taken,
    trunk_pose_at,
)
from robot.manipulation.pick import PickFailed
from robot.manipulation.stand_up import arm_back_moves, standing_up_with
from robot.model import humanoid_v1
from robot.model.world import WorldLayout
from robot.navigation.navigator import NavigationFailed, Navigator
from robot.planning.executor import ExecutionContext
from robot.skills.body import BodyParts
from robot.skills.detect import Looking

LOCATE_TIMEOUT_S = 2.0
STAGING_BACK_M = 0.12
STANCE_SETTLE_M = 0.02
STEP_TO_M = 0.6  # nearer than this, the stance is corrected by a straight walk


class ArmBody:
    """The arm, the legs and the eyes for one manipulation step. `navigator`: walks for this step; `blocked`:
    whether a map point is taken (None before the first map); `walk_ended`: a walk of this step is over."""

    def __init__(
        self,
        parts: BodyParts,
        layout: WorldLayout,
        ctx: ExecutionContext,
        looking: Looking,
        navigator: Callable[[ExecutionContext], Navigator],
        blocked: Callable[[], Callable[[float, float], bool] | None],
        walk_ended: Callable[[], None],
    ) -> None:
        self._parts = parts
        self._layout = layout
        self._ctx = ctx
        self._looking = looking
        self._navigator = navigator
        self._blocked = blocked
        self._walk_ended = walk_ended

    def locate(self, name: str, near: np.ndarray | None = None) -> np.ndarray | None:
        perception = self._parts.perception
        assert perception is not None
        if near is None:
            remembered = perception.memory.get(name)
            if remembered is None:
                return None
            near = np.asarray(remembered.position)
        self._looking.look_at(near)
        clock = self._parts.clock
        deadline = clock.now() + LOCATE_TIMEOUT_S
        while clock.now() < deadline:
            for detection in self._looking.fresh_detections():
                if detection.label == name:
                    return np.array(detection.position, dtype=float)
            self._ctx.wait_sim(0.05)
        return None

    def to_feet(self, point_in_map: np.ndarray) -> np.ndarray:
        position, rotation = self._parts.localiser.map_trunk()
        in_trunk = rotation.T @ (np.asarray(point_in_map, dtype=float) - position)
        trunk = self._parts.arm.motion().trunk_in_feet(self._parts.arm.joint_positions())
        return trunk[:3, :3] @ in_trunk + trunk[:3, 3]

    def comfortably_reaches(self, point_in_map: np.ndarray, hand: Hand = "right") -> bool:
        """Whether `hand` reaches the map point from where the robot stands, with a margin to spare."""
        return comfortably_in_reach(self.to_feet(point_in_map), hand=hand)

    def sideways_clear(self, hand: Hand = "right") -> bool:
        blocked = self._blocked()
        return blocked is None or not arm_sweep_taken(replace(self.feet_stance(), hand=hand), blocked, True)

    def feet_stance(self) -> Stance:
        """Where the feet stand now (their centre and heading, map frame), by the localiser."""
        position, rotation = self._parts.localiser.map_trunk()
        feet_in_trunk = np.linalg.inv(self._parts.arm.motion().trunk_in_feet(self._parts.arm.joint_positions()))
        centre = rotation @ feet_in_trunk[:3, 3] + position
        axes = rotation @ feet_in_trunk[:3, :3]
        return Stance(float(centre[0]), float(centre[1]), float(math.atan2(axes[1, 0], axes[0, 0])))

    def go_to(self, stance: Stance, reach: np.ndarray | None = None) -> None:
        blocked = self._blocked()
        if blocked is not None and stance_taken(stance, blocked):
            raise PickFailed(no_room_to_stand("object", stance))
        good_stop = None if reach is None else (lambda: self.comfortably_reaches(reach, stance.hand))
        self._parts.head.point(0.0, DEFAULT_TILT)
        goal = self.trunk_goal(stance)
        x, y, yaw = goal
        back = (x - STAGING_BACK_M * math.cos(yaw), y - STAGING_BACK_M * math.sin(yaw))
        navigator = self._navigator(self._ctx)
        position, _ = self._parts.localiser.map_trunk()
        here = (float(position[0]), float(position[1]))
        try:
            if math.dist(here, (x, y)) < STEP_TO_M:  # the reach window is +-4 cm: settle tightly
                navigator.step_to(goal, STANCE_SETTLE_M, good_stop)
            else:
                navigator.go(back, goal, good_stop)
        except NavigationFailed as exc:
            raise PickFailed(str(exc)) from exc
        finally:
            self._walk_ended()

    def trunk_goal(self, stance: Stance) -> tuple[float, float, float]:
        """The trunk's pose to walk to for the feet to stand at `stance`, with the arms as they are now."""
        arm = self._parts.arm
        return trunk_pose_at(stance, arm.motion().trunk_ahead_of_com(arm.joint_positions()))

    def stance_for(self, point_in_map: np.ndarray, hand: Hand = "right") -> Stance:
        """Where to stand to grasp at the map point: for `hand` where it has room, else for the other one."""
        x, y = float(point_in_map[0]), float(point_in_map[1])
        place = next((p for p in self._layout.places if p.surface is not None and p.surface.contains(x, y)), None)
        if place is None:
            position, _ = self._parts.localiser.map_trunk()
            return grasp_stance((x, y), math.atan2(y - position[1], x - position[0]), self._blocked(), hand)
        facings = stance_facings(place.approach[2], place.surface, (x, y))
        return grasp_stance_facing_any((x, y), facings, self._blocked(), (hand, other_hand(hand)))

    def arm(self, moves: list[Move], hand: Hand | None = None) -> None:
        """Play `moves`, reaching with `hand` (None: the hand that reached last, which may hold something)."""
        arm_part = self._parts.arm
        if not arm_part.active:
            # a walk that has just ended may still be moving to the standing posture: reaching from the posture half
            # way (knees deep as when carrying) made the first hand move snap the legs straight and tip the robot
            self._wait_standing()
        arm = arm_part.take(hand)
        arm.queue(*moves)
        try:
            while not arm.done.is_set():
                self._ctx.wait_sim(0.02)
                if self._parts.legs.fallen():
                    raise PickFailed("fell while reaching")
        except BaseException:
            arm.stop()
            raise

    def grip_opening(self) -> float:
        """The reaching hand's measured finger opening (m each)."""
        grip = f"{self._parts.arm.hand[0]}_grip"
        return float(self._parts.arm.joint_positions()[humanoid_v1.JOINT_NAMES.index(grip)])

    def stand_holding(self) -> None:
        arm = self._parts.arm
        self.arm(standing_up_with(carry_moves(arm.hand), arm.default_stand))
        arm.release(arm.motion().targets)
        self._wait_standing()

    def stow_arm(self, finish_in_background: bool = False) -> None:
        arm = self._parts.arm
        first, *rest = standing_up_with(arm_back_moves(arm.hand), arm.default_stand)
        if finish_in_background:
            # the hand is out of the camera's view once swung back: the rest (1.6 s) goes on while the next steps run
            self.arm([first])
            arm.finish_in_background(rest)
            return
        self.arm([first, *rest])
        arm.release(None)
        self._wait_standing()

    def _wait_standing(self) -> None:
        while not self._parts.arm.standing:
            self._ctx.wait_sim(0.02)
