"""The `pick_object` and `place_object` steps, and where to stop at a place for them (the walk before asks)."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.manipulation.grasp_plan import (
    Hand,
    grasp_stance,
    grasp_stance_facing_any,
    no_room_to_stand,
    stance_facings,
    stance_taken,
)
from robot.manipulation.pick import PickFailed, pick
from robot.manipulation.place import PlaceFailed, choose_spot, spots_in_reach
from robot.manipulation.place import place as place_held
from robot.model.world import Place, WorldLayout
from robot.navigation.costmap import Costmap
from robot.navigation.navigator import Navigator
from robot.perception.geometry import yaw_of
from robot.planning.executor import ExecutionContext, StepFailed
from robot.planning.world_context import WorldContext
from robot.skills.arm_body import ArmBody
from robot.skills.body import BodyParts
from robot.skills.detect import Looking


class ManipulateSkill:
    """`navigator`: walks for a step; `walk_ended`: a step's walk is over (the legs stop, the path is cleared);
    `looking`: the head and legs for a step's looks."""

    def __init__(
        self,
        parts: BodyParts,
        layout: WorldLayout,
        world: Callable[[], WorldContext],
        publish: Callable[..., Any],
        navigator: Callable[[ExecutionContext], Navigator],
        walk_ended: Callable[[], None],
        looking: Callable[[ExecutionContext], Looking],
    ) -> None:
        self._parts = parts
        self._layout = layout
        self._world = world
        self._publish = publish
        self._navigator = navigator
        self._walk_ended = walk_ended
        self._looking = looking

    def arm_body(self, ctx: ExecutionContext) -> ArmBody:
        return ArmBody(
            self._parts, self._layout, ctx, self._looking(ctx), self._navigator, self.map_blocked, self._walk_ended
        )

    def pick_object(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Stand where the object is in a hand's reach (the right one's where there is room), grasp it with
        contacts only, lift it and check it rose with the hand; then stand up holding it, ready to walk."""
        if self._parts.perception is None:
            raise StepFailed("picking needs the camera, and perception is off in this worker")
        name = self._world().resolve_object(args["object"]) or args["object"]
        obj = next((o for o in self._layout.objects if o.name == name), None)
        if obj is None:
            raise StepFailed(f"unknown object {args['object']!r}")
        held = self._parts.arm.held
        if held is not None:
            raise StepFailed(f"already holding the {held}: place it first")
        try:
            report = pick(name, obj.height, self.arm_body(ctx), round_object=obj.round)
        except BaseException as exc:  # failed, cancelled or stopped midway: the fingers may have closed on it yet
            if self._parts.arm.grasping():
                self._parts.arm.hold_object(name)
            if isinstance(exc, PickFailed):
                raise StepFailed(str(exc)) from exc
            raise
        finally:
            self._walk_ended()
        self._parts.arm.hold_object(name)
        self._publish(
            "manipulation/picked",
            f"holding the {name}",
            name=name,
            grip_mm=report.grip_m * 2000,
            rise_m=report.rise_m,
            stance_corrections=report.stance_corrections,
        )
        return f"holding the {name}: lifted {report.rise_m * 100:.1f} cm, gripper {report.grip_m * 2000:.0f} mm open"

    def place_object(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Put the held object down on a named surface, at a free spot in front of the robot, and check it stands
        there."""
        if self._parts.perception is None:
            raise StepFailed("placing needs the camera, and perception is off in this worker")
        held = self._parts.arm.held
        if held is None:
            raise StepFailed("not holding anything to place")
        name = self._world().resolve_place(args["location"])
        place = next((p for p in self._layout.places if p.name == name), None)
        if place is None:
            raise StepFailed(f"unknown place {args['location']!r}")
        obj = next(o for o in self._layout.objects if o.name == held)
        # a free spot in reach from where the robot stopped, else the one in front of the place (walking there)
        spot = self.place_spot_here(place, held, self.arm_body(ctx))
        if spot is None:
            spot = self.place_spot(place, held)
        if spot is None:
            raise StepFailed(f"unreachable: no free spot on the {place.name} in front of the robot")
        try:
            report = place_held(
                held,
                obj.height,
                spot,
                place.approach[2],
                self.arm_body(ctx),
                round_object=obj.round,
                hand=self._parts.arm.hand,
            )
        except BaseException as exc:  # failed, cancelled or stopped midway: the hand may have let go of it already
            if not self._parts.arm.grasping():
                self._parts.arm.hold_object(None)
            if isinstance(exc, (PlaceFailed, PickFailed)):
                raise StepFailed(str(exc)) from exc
            raise
        finally:
            self._walk_ended()
        self._parts.arm.hold_object(None)
        x, y, _ = report.position
        self._publish(
            "manipulation/placed",
            f"put the {held} on the {place.name}",
            name=held,
            place=place.name,
            position=list(report.position),
            error_m=report.error_m,
            stance_corrections=report.stance_corrections,
        )
        return f"put the {held} on the {place.name} at ({x:.2f}, {y:.2f}), {report.error_m * 100:.1f} cm from the spot"

    def place_spot(self, place: Place, held: str) -> np.ndarray | None:
        """Where on the place's surface to put the held object, seen from the place's approach: free of what the
        robot remembers standing there."""
        if place.surface is None:
            return None
        return choose_spot(place.surface, place.approach, self._occupied_except(held))

    def place_spot_here(self, place: Place, held: str, arm: ArmBody) -> np.ndarray | None:
        """A free spot on the place's surface comfortably in the hand's reach from where the robot stands, if any."""
        if place.surface is None:
            return None
        position, rotation = self._parts.localiser.map_trunk()
        pose = (float(position[0]), float(position[1]), yaw_of(rotation))
        hand = self._parts.arm.hand
        spots = spots_in_reach(place.surface, pose, self._occupied_except(held), hand)
        return next((spot for spot in spots if arm.comfortably_reaches(spot, hand)), None)

    def _occupied_except(self, held: str) -> list[tuple[float, float]]:
        """Where the objects the robot remembers stand (map, m), but the one it holds."""
        perception = self._parts.perception
        assert perception is not None
        return [k.position[:2] for k in perception.memory.snapshot() if k.name != held]

    def work_pose(
        self, place: Place, ctx: ExecutionContext
    ) -> tuple[tuple[float, float, float], Callable[[], bool] | None]:
        """Where to stop at a place, and whether a stop will do for the work there (asked at each stop: the camera
        keeps refining an object's position on the way): if the plan next picks an object seen there, the stance
        with it in reach, and a stop that has it comfortably in reach will do; if it next puts something down
        there, the stance for a free spot, and a stop with any free spot in reach will do (saves correction walks
        at the surface); otherwise the place's own approach pose, and nothing."""
        perception = self._parts.perception
        assert perception is not None
        arm = self.arm_body(ctx)
        for step in ctx.upcoming:
            if step.action == "navigate_to":
                break
            if step.action == "place_object":
                held = self._parts.arm.held or ""
                spot = self.place_spot(place, held)
                if spot is not None and self._world().resolve_place(step.args["location"]) == place.name:
                    stance = grasp_stance(
                        (float(spot[0]), float(spot[1])), place.approach[2], hand=self._parts.arm.hand
                    )
                    return arm.trunk_goal(stance), functools.partial(self._has_spot_here, place, held, arm)
                continue
            if step.action != "pick_object" or place.surface is None:
                continue
            name = self._world().resolve_object(step.args["object"]) or step.args["object"]
            remembered = perception.memory.get(name)
            if remembered is not None and place.surface.contains(*remembered.position[:2]):
                blocked = self.map_blocked()
                xy = (float(remembered.position[0]), float(remembered.position[1]))
                stance = grasp_stance_facing_any(xy, stance_facings(place.approach[2], place.surface, xy), blocked)
                if blocked is not None and stance_taken(stance, blocked):
                    raise StepFailed(no_room_to_stand(name, stance))
                return arm.trunk_goal(stance), functools.partial(self._remembered_in_reach, name, arm, stance.hand)
        return place.approach, None

    def _has_spot_here(self, place: Place, held: str, arm: ArmBody) -> bool:
        return self.place_spot_here(place, held, arm) is not None

    def _remembered_in_reach(self, name: str, arm: ArmBody, hand: Hand) -> bool:
        perception = self._parts.perception
        assert perception is not None
        known = perception.memory.get(name)
        return known is not None and arm.comfortably_reaches(np.asarray(known.position, dtype=float), hand)

    def map_blocked(self) -> Callable[[float, float], bool] | None:
        """Whether a map point is taken on the lidar map (obstacles not grown) or by the apartment's walls; None
        before the first map."""
        grid = self._parts.perception.feed().map if self._parts.perception is not None else None
        if grid is None:
            return None
        on_map, walls = Costmap.from_map(grid, 0.0).blocked_at, self._layout.in_or_beyond_walls
        return lambda x, y: on_map(x, y) or walls(x, y)
