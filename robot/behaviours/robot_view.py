"""`BehaviourRobot`: the robot as a behaviour's code sees it, built on the skills plan steps use (walk to a place,
look for an object, pick, place, look around, say) plus the head, the gestures, the world memory and a way to
report (feedback lines, progress, a camera snapshot). Every call blocks in simulated time and raises `Cancelled`
once the behaviour is paused or stopped (or its step overran), so user code needs no checks of its own."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from robot.behaviours.errors import BehaviourFailed, NoRoomToGesture
from robot.behaviours.gestures import NoRoom, perform
from robot.behaviours.routes import waypoint_near
from robot.interface import DetectedObject, KnownObject, OccupancyMap, Plan, Step
from robot.model.world import Place, WorldLayout
from robot.perception.geometry import yaw_of
from robot.planning.executor import Capability, ExecutionContext, StepFailed
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext
from robot.skills.body import BodyParts
from robot.skills.catalogue import Skills
from robot.skills.walk_rest import StillHot, stand_until_cool

# A behaviour's walk starts only with every servo WALK_HEADROOM_K below the diagnostics' warning (65 C), 20 K below
# where they stop the robot (75 C): hotter, the robot stands and rests until the hottest is COOL_MARGIN_K cooler
# still. Walking warms the knees ~0.3 K a second in simulation (they settle near 150 C walking, 37 C standing, with a
# time constant of 6 min): a long patrol reached 75 C (bench world seed 18), and so did one whose last walk started
# just below the warning (65 s of walking from 61 C). From 55 C a knee takes about 85 s of walking to reach 75 C.
WALK_HEADROOM_K = 10.0
COOL_MARGIN_K = 5.0


class Reporter(Protocol):
    """Where a behaviour's reports go (the run: its status and the session's events)."""

    def feedback(self, line: str) -> None: ...

    def progress(self, fraction: float) -> None: ...

    def snapshot(self, message: str, data: dict[str, Any]) -> None: ...

    def next_command(self) -> str | None: ...


class BehaviourRobot:
    """One state's step's view of the robot. `capabilities`: the plan actions (the skills, with the arm settled
    first where they need the joints)."""

    def __init__(
        self,
        parts: BodyParts,
        skills: Skills,
        capabilities: dict[str, Capability],
        layout: WorldLayout,
        world: Callable[[], WorldContext],
        ctx: ExecutionContext,
        reporter: Reporter,
        plan: Callable[[str], Plan],
    ) -> None:
        self._parts = parts
        self._skills = skills
        self._capabilities = capabilities
        self._layout = layout
        self._world = world
        self._ctx = ctx
        self._reporter = reporter
        self._plan = plan
        self._rested_s = 0.0
        self._walks_rested_before_s = skills.navigate.rested_s

    @property
    def rested_s(self) -> float:
        """Simulated seconds spent resting for the servos' heat, before a walk (`rest_if_hot`) or partway through one
        (`ServoRest`): the robot's time, not the step's (the runner does not count it against the step's timeout)."""
        return self._rested_s + self._skills.navigate.rested_s - self._walks_rested_before_s

    # ---------------------------------------------------------------------------------------------------------
    # what the robot knows

    @property
    def places(self) -> tuple[str, ...]:
        return self._layout.place_names

    @property
    def objects(self) -> tuple[str, ...]:
        return self._layout.object_names

    @property
    def start_pose(self) -> tuple[float, float, float]:
        """Where the robot started (x, y, heading rad)."""
        return self._layout.robot_start

    def place(self, name: str) -> Place:
        place = next((p for p in self._layout.places if p.name == name), None)
        if place is None:
            raise BehaviourFailed(f"unknown place {name!r}")
        return place

    def waypoint_near(self, point: tuple[float, float]) -> tuple[float, float]:
        """Open floor near `point` with room to turn, clear of the walls and furniture the world model knows."""
        return waypoint_near(self._layout, point)

    def pose(self) -> tuple[float, float, float]:
        """Where the robot believes it is on its map: x, y (m), heading (rad)."""
        position, rotation = self._parts.localiser.map_trunk()
        return float(position[0]), float(position[1]), yaw_of(rotation)

    def known_objects(self) -> tuple[KnownObject, ...]:
        """What the world memory holds: every object seen, where and when."""
        perception = self._parts.perception
        return perception.memory.snapshot() if perception is not None else ()

    def remembered(self, name: str) -> KnownObject | None:
        perception = self._parts.perception
        return perception.memory.get(name) if perception is not None else None

    def believed_place(self, obj: str) -> str | None:
        """The place an object is believed to be on (where it was last seen, else where the world says)."""
        return self._world().object_locations.get(obj)

    def seen_now(self) -> tuple[DetectedObject, ...]:
        """The detections of the next camera frame."""
        self._ctx.check_cancelled()
        perception = self._parts.perception
        if perception is None:
            return ()
        return perception.detections_after(self._parts.clock.now())

    def occupancy(self) -> OccupancyMap | None:
        """The lidar map now (None before the first)."""
        perception = self._parts.perception
        return perception.feed().map if perception is not None else None

    @property
    def holding(self) -> str | None:
        return self._parts.arm.held

    def still_holding(self) -> bool:
        """Whether the fingers still hold what the robot picked up (by the fingers, not the bookkeeping: an object
        can slip out on the way)."""
        return self._parts.arm.held is not None and self._parts.arm.grasping()

    @property
    def sim_time_s(self) -> float:
        return self._parts.clock.now()

    # ---------------------------------------------------------------------------------------------------------
    # skills (each as the plan step of the same name)

    def go_to(self, target: str, to_pick: str | None = None, to_place: str | None = None) -> str:
        """Walk to a named place, or a pose "x, y" / "x, y, heading deg" (m), round obstacles on the map; with
        `to_pick` (an object) or `to_place` (a place), stop where that work can be done from."""
        self.rest_if_hot()
        upcoming: tuple[Step, ...] = ()
        if to_pick is not None:
            upcoming = (Step("pick_object", {"object": to_pick}),)
        elif to_place is not None:
            upcoming = (Step("place_object", {"location": to_place}),)
        return self._do("navigate_to", upcoming, target=target)

    def rest_if_hot(self) -> None:
        """Stand still while a servo is too hot for a walk (`WALK_HEADROOM_K`), saying so, until it has cooled
        (`COOL_MARGIN_K`): walking on, it would heat to where the diagnostics stop the robot. `BehaviourFailed` if
        it stays hot for `walk_rest.MAX_REST_S`."""
        heat = self._parts.servo_heat
        if heat is None:
            return
        joint, temperature = heat.hottest()
        if temperature < heat.hot_c - WALK_HEADROOM_K:
            return
        cool_c = heat.hot_c - WALK_HEADROOM_K - COOL_MARGIN_K
        self.feedback(f"resting: the {joint} servo is at {temperature:.0f} C; walking on below {cool_c:.0f} C")
        started = self.sim_time_s
        try:
            joint, temperature = stand_until_cool(heat, cool_c, self.wait, self._count_rest)
        except StillHot as hot:
            raise BehaviourFailed(str(hot)) from hot
        self.feedback(f"rested {self.sim_time_s - started:.0f} s: the hottest servo is at {temperature:.0f} C")

    def _count_rest(self, seconds: float) -> None:
        self._rested_s += seconds

    def detect(self, obj: str) -> str:
        """Look for an object (head, then body) and remember where it is; `BehaviourFailed` if not found."""
        return self._do("detect_object", object=obj)

    def pick(self, obj: str) -> str:
        return self._do("pick_object", object=obj)

    def put_down(self, place: str) -> str:
        return self._do("place_object", location=place)

    def look_around(self) -> str:
        return self._do("look_around")

    def go_home(self) -> str:
        return self._do("go_home")

    def say(self, text: str) -> str:
        return self._do("say", text=text)

    def wait(self, seconds: float) -> None:
        self._ctx.wait_sim(seconds)

    def face(self, point: tuple[float, float] | tuple[float, float, float]) -> None:
        """Turn in place to face a point on the map."""
        self._ctx.check_cancelled()
        target = (float(point[0]), float(point[1]), 0.0)
        try:
            self._skills.detect.looking(self._ctx).face(target)
        except StepFailed as exc:
            raise BehaviourFailed(str(exc)) from exc

    def look_at(self, point: tuple[float, float, float]) -> bool:
        """Aim the head at a map point (blocks); False when it is out of the head's reach."""
        self._ctx.check_cancelled()
        return self._skills.detect.looking(self._ctx).look_at(point)

    def gesture(self, name: str, at: str | None = None) -> str:
        """ "wave", "nod", "shake_head", or "point" `at` an object the robot has seen (it turns to face it)."""
        self._ctx.check_cancelled()

        def aim() -> float:
            assert at is not None
            known = self.remembered(at)
            if known is None:
                raise BehaviourFailed(f"cannot point at the {at}: not seen yet")
            self.face(known.position)
            self.look_at(known.position)
            x, y, _ = self.pose()
            shoulder_height = 0.35  # about where the shoulder is above the floor (m)
            distance = math.hypot(known.position[0] - x, known.position[1] - y)
            return math.atan2(shoulder_height - known.position[2], max(distance, 0.1))

        def turn(angle: float) -> None:
            self._skills.detect.looking(self._ctx).turn_in_place(angle)

        try:
            return perform(name, self._parts, self._ctx, aim if at is not None else None, turn)
        except NoRoom as exc:
            raise NoRoomToGesture(str(exc)) from exc
        except StepFailed as exc:
            raise BehaviourFailed(str(exc)) from exc

    # ---------------------------------------------------------------------------------------------------------
    # commands (a behaviour that `listens`)

    def next_command(self, wait_s: float = 0.0) -> str | None:
        """The next typed or spoken command said to the behaviour, waiting up to `wait_s` simulated seconds."""
        waited = 0.0
        while True:
            self._ctx.check_cancelled()
            text = self._reporter.next_command()
            if text is not None or waited >= wait_s:
                return text
            self._ctx.wait_sim(0.1)
            waited += 0.1

    def run_command(self, text: str) -> str:
        """Plan a command as the planner reads it and do its steps; what was done, step by step."""
        try:
            plan = self._plan(text)
        except PlanningError as exc:
            raise BehaviourFailed(f"did not understand {text!r}: {exc}") from exc
        done = []
        for index, step in enumerate(plan.steps):
            if step.action not in self._capabilities:
                raise BehaviourFailed(f"cannot {step.action} here")
            done.append(self._do(step.action, plan.steps[index + 1 :], **step.args))
        return "; ".join(done)

    # ---------------------------------------------------------------------------------------------------------
    # reporting

    def feedback(self, line: str) -> None:
        """A line the operator reads as the behaviour goes (and the session keeps)."""
        self._ctx.check_cancelled()
        self._reporter.feedback(line)

    def progress(self, fraction: float) -> None:
        self._ctx.check_cancelled()
        self._reporter.progress(float(np.clip(fraction, 0.0, 1.0)))

    def snapshot(self, message: str, **data: Any) -> None:
        """Report something noticed with the camera's view now (kept with the session)."""
        self._ctx.check_cancelled()
        perception = self._parts.perception
        image = perception.feed().camera if perception is not None else None
        frame = {"frame_seq": image.seq, "frame_sim_s": image.sim_time_s} if image is not None else {}
        self._reporter.snapshot(message, {**data, **frame})

    def _do(self, action: str, upcoming: tuple[Step, ...] = (), **args: str) -> str:
        self._ctx.check_cancelled()
        try:
            return self._capabilities[action](args, replace(self._ctx, upcoming=upcoming))
        except StepFailed as exc:
            raise BehaviourFailed(str(exc)) from exc
