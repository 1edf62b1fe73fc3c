"""Looking for an object: the head first, then the body turning (`Looking`, the object search's body), and the
`detect_object` step, whose find goes into the world memory. Each call blocks in simulated time and gives up
when the plan is cancelled."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.control.locomotion import Velocity
from robot.interface import DetectedObject
from robot.model.world import WorldLayout
from robot.perception.geometry import yaw_of
from robot.perception.search import ObjectNotFound, find_object
from robot.perception.sensor_process import SensorError
from robot.planning.executor import ExecutionContext, StepFailed
from robot.planning.world_context import WorldContext
from robot.skills.body import BodyParts, Head, Legs, Localiser, PerceptionView

# Turning in place for a task (looking for an object, facing a point).
TURN_RATE_RAD_S = 0.5
TURN_TOLERANCE_RAD = 0.12
# A turn in place that is blocked (an arm against the counter at a tour's stop) backs this far straight away from
# what the robot faces, at this speed, and turns again once (m, m/s).
BACK_OFF_M = 0.1
BACK_OFF_M_S = 0.05
# After the head reaches its target, the image is steady after this long (s).
HEAD_SETTLE_S = 0.15


class Looking:
    """The robot's head and legs as a plan step looks with them (the object search's `SearchBody`)."""

    def __init__(
        self,
        head: Head,
        legs: Legs,
        localiser: Localiser,
        perception: PerceptionView | None,
        now: Callable[[], float],
        ctx: ExecutionContext,
    ) -> None:
        self._head = head
        self._legs = legs
        self._localiser = localiser
        self._perception = perception
        self._now = now
        self._ctx = ctx

    def point_head(self, pan: float, tilt: float) -> None:
        self._head.point(pan, tilt)
        while not self._head.at_target:
            self._ctx.wait_sim(0.02)
        self._ctx.wait_sim(HEAD_SETTLE_S)

    def look_at(self, target: tuple[float, float, float] | np.ndarray) -> bool:
        position, rotation = self._localiser.map_trunk()
        pan, tilt, reachable = self._head.angles_to_look_at(position, rotation, np.asarray(target))
        if reachable:
            self.point_head(pan, tilt)
        return reachable

    def face(self, target: tuple[float, float, float]) -> None:
        position, rotation = self._localiser.map_trunk()
        heading = math.atan2(target[1] - position[1], target[0] - position[0])
        self.turn_in_place(wrap(heading - yaw_of(rotation)))

    def turn_in_place(self, angle: float) -> None:
        """Turn by `angle` (rad); a turn blocked by something the arm touches backs off BACK_OFF_M and turns on."""
        legs = self._legs
        self._head.point(0.0, self._head.target[1])
        turned, last = 0.0, self._yaw()
        backed_off = False
        try:
            for rate in (TURN_RATE_RAD_S, TURN_RATE_RAD_S / 2):  # a second, slower turn takes up the overshoot
                remaining = angle - turned
                if abs(remaining) < TURN_TOLERANCE_RAD:
                    break
                direction = math.copysign(1.0, remaining)
                legs.drive(Velocity(0.0, 0.0, direction * rate))
                # a turn that takes three times as long as it should is blocked (an arm against furniture)
                deadline = self._turn_deadline(angle - turned, rate)
                # stop early by about what the two stopping steps still turn
                while direction * (angle - turned) > rate * 0.3:
                    if self._now() > deadline:
                        if backed_off:
                            raise StepFailed(
                                f"could not turn in place: turned {math.degrees(turned):.0f} of "
                                f"{math.degrees(angle):.0f} deg (blocked?)"
                            )
                        backed_off = True
                        self._back_off()
                        legs.drive(Velocity(0.0, 0.0, direction * rate))
                        deadline = self._turn_deadline(angle - turned, rate)
                    self._ctx.wait_sim(0.02)
                    yaw = self._yaw()
                    turned += wrap(yaw - last)
                    last = yaw
                legs.drive(Velocity())
                while legs.moving:
                    self._ctx.wait_sim(0.02)
                yaw = self._yaw()
                turned += wrap(yaw - last)
                last = yaw
        finally:
            legs.drive(Velocity())

    def _turn_deadline(self, remaining: float, rate: float) -> float:
        return self._now() + 3.0 * abs(remaining) / rate + 3.0

    def _back_off(self) -> None:
        """Stop, then walk straight back BACK_OFF_M: what blocks a turn in place is what the robot stands facing."""
        legs = self._legs
        legs.drive(Velocity())
        while legs.moving:
            self._ctx.wait_sim(0.02)
        legs.drive(Velocity(-BACK_OFF_M_S, 0.0, 0.0))
        end = self._now() + BACK_OFF_M / BACK_OFF_M_S
        while self._now() < end:
            self._ctx.wait_sim(0.02)
        legs.drive(Velocity())
        while legs.moving:
            self._ctx.wait_sim(0.02)

    def fresh_detections(self) -> tuple[DetectedObject, ...]:
        assert self._perception is not None
        return self._perception.detections_after(self._now())

    def _yaw(self) -> float:
        return yaw_of(self._localiser.map_trunk()[1])


class DetectSkill:
    """The `detect_object` step. `world`: the world as the robot knows it now (names, where things are)."""

    def __init__(
        self,
        parts: BodyParts,
        layout: WorldLayout,
        world: Callable[[], WorldContext],
        publish: Callable[..., Any],
    ) -> None:
        self._parts = parts
        self._layout = layout
        self._world = world
        self._publish = publish

    def looking(self, ctx: ExecutionContext) -> Looking:
        p = self._parts
        return Looking(p.head, p.legs, p.localiser, p.perception, p.clock.now, ctx)

    def detect_object(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Look for the object (head, then body); found: its 3D position goes into the world memory."""
        perception = self._parts.perception
        if perception is None:
            raise StepFailed("perception is off in this worker")
        name = self._world().resolve_object(args["object"]) or args["object"]
        remembered = perception.memory.get(name)
        believed = remembered.position if remembered else self.expected_position(name)
        try:
            result = find_object(name, self.looking(ctx), believed, ctx.check_cancelled)
        except ObjectNotFound as exc:
            raise StepFailed(str(exc)) from exc
        except SensorError as exc:
            raise StepFailed(f"camera unavailable: {exc}") from exc
        finally:
            self._parts.legs.drive(Velocity())
        found = result.detection
        x, y, z = found.position
        place = perception.memory.place_of(found.position)
        where = f" on the {place}" if place and place != "floor" else ""
        self._publish(
            "perception/object_found",
            f"found the {name} at ({x:.3f}, {y:.3f}, {z:.3f}){where}",
            name=name,
            position=list(found.position),
            distance_m=found.distance_m,
            confidence=found.confidence,
            views=result.views,
        )
        return f"found {name} at ({x:.3f}, {y:.3f}, {z:.3f}) m, {found.distance_m:.2f} m away{where}"

    def expected_position(self, name: str) -> tuple[float, float, float] | None:
        """Where the world model says an object should be: the middle of the place it is on (not where it is)."""
        place = self._world().object_locations.get(name)
        for p in self._layout.places:
            if p.name == place and p.surface is not None:
                return (p.surface.x, p.surface.y, p.surface.height)
        return None


def wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))
