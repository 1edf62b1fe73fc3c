"""Walking to a place or a pose on the robot's own map: the legs and the map as the navigator uses them
(`LegsAndMap`), and the `navigate_to` step, which stops where the next step's work can be done."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

from robot.control.head import DEFAULT_TILT
from robot.control.locomotion import Velocity, clip_velocity
from robot.interface import NavigationState
from robot.manipulation.grasp_plan import CARRY_HAND_AHEAD_M, same_facing
from robot.model.world import FEET_REACH_M, ROBOT_RADIUS, Box, Place, WorldLayout, is_mat, near_mat_edges
from robot.navigation.costmap import Costmap
from robot.navigation.follower import MAX_FORWARD_M_S
from robot.navigation.goal import PoseGoal, parse_pose_goal
from robot.navigation.navigator import (
    CARRYING_CLEARANCE_M,
    CLEARANCE_M,
    OPEN_M_S,
    TURN_ROOM_M,
    NavigationFailed,
    NavigationReport,
    Navigator,
    StopDrift,
)
from robot.perception.geometry import yaw_of
from robot.planning.executor import ExecutionContext, StepFailed
from robot.planning.world_context import WorldContext
from robot.skills.body import BodyParts, Legs, Localiser, PerceptionView
from robot.skills.walk_rest import ServoRest

CARRY_CLEARANCE_M = 0.02  # between the carried object and a surface's edge, before turning away from it
MIN_STEP_BACK_M = 0.04
# A work pose facing a place as its approach does (`same_facing`) is walked onto from the place's staging point; one
# facing it another way from a point this far behind it (the nearest free on the map).
WORK_STAGING_BACK_M = (0.12, 0.25, 0.4)
# A place on a mat (the dock's pad) is walked onto straight along its heading, from this far beyond the mat's edge
# (the feet 10 cm off it): a path ending on the mat came at it aslant, a foot landed on its corner, the trunk tilted
# 6-10 degrees and, with the arms held back, the robot fell backwards (tours to the dock on world 2: 2 of 6). The stop
# there can end 10 cm past it, still turning (world 2, 1 of 4 runs at 0.25 m): that far leaves the feet clear of the
# edge all the same.
MAT_ENTRY_M = 0.35
# Paths keep the robot's centre this far from a mat's edge (on it or off it): the feet reach `FEET_REACH_M`, and a
# path along the pad's edge to its entry turned in place 10 cm off the edge (a typed pose on the dock, world 2).
MAT_EDGE_KEEP_OFF_M = FEET_REACH_M + 0.05
# The straight ways onto and off a mat keep this much room beyond the footprint where one can, as paths do (less where
# none can): a patrol leaving the dock walked off it 16 cm from a box by its side, the least the footprint allows, and
# a shoulder touched the box (world seed 14). Checked beyond `MAT_WAY_FROM_M` of the pose on the mat: the dock sits in
# a corner, and the room there is the same whichever way the robot leaves.
MAT_WAY_CLEARANCES_M = (CLEARANCE_M, CLEARANCE_M / 2, 0.0)
MAT_WAY_FROM_M = 0.15


def mat_entry(place: Place) -> tuple[float, float]:
    """Where the walk onto a place on a mat starts: in line with its approach pose, `MAT_ENTRY_M` beyond the mat's
    edge along the pose's heading (the robot walks back onto it, both feet crossing the edge squarely)."""
    assert place.surface is not None
    x, y, yaw = place.approach
    return entry_along(place.surface, x, y, yaw)


def entry_along(mat: Box, x: float, y: float, yaw: float) -> tuple[float, float]:
    """The point `MAT_ENTRY_M` beyond the mat's edge, from (x, y) along `yaw`: a walk between it and (x, y) crosses
    the edge in line with `yaw`."""
    direction = (math.cos(yaw), math.sin(yaw))
    # how far the heading runs from the pose to the mat's edge
    to_edge = min(
        (centre + math.copysign(half, d) - p) / d
        for centre, half, p, d in ((mat.x, mat.half_x, x, direction[0]), (mat.y, mat.half_y, y, direction[1]))
        if abs(d) > 1e-9
    )
    reach = max(to_edge, 0.0) + MAT_ENTRY_M
    return round(x + reach * direction[0], 3), round(y + reach * direction[1], 3)


def mat_under(layout: WorldLayout, x: float, y: float) -> Box | None:
    """The mat a robot standing at (x, y) would have a foot on or beside (within `FEET_REACH_M` of it), if any."""
    return next((box for box in layout.furniture if is_mat(box) and box.contains(x, y, FEET_REACH_M)), None)


def pose_entries(mat: Box, x: float, y: float, yaw: float | None) -> list[tuple[tuple[float, float], float]]:
    """Ways onto a pose on a mat, each an entry point and the heading kept from it to the pose: with a heading,
    walking back onto the pose from ahead of it or on from behind it; without one, walking on squarely across any
    of the mat's four edges."""
    if yaw is not None:
        return [(entry_along(mat, x, y, yaw), yaw), (entry_along(mat, x, y, yaw + math.pi), yaw)]
    return [
        (entry_along(mat, x, y, heading + math.pi), heading) for heading in (0.0, math.pi / 2, math.pi, -math.pi / 2)
    ]


# A way onto a mat: the entry beyond its edge, and the stance on it (x, y, heading) walked onto straight from there.
MatWay = tuple[tuple[float, float], tuple[float, float, float]]
# The way onto a mat moved this far or more when the robot got to its entry (the map changed at the last moment): it
# walks to the new entry on a planned path before it steps on.
WAY_MOVED_M = 0.15


# Within this of the way's entry, the way onto a mat is held (`HeldWay`).
HOLD_WAY_WITHIN_M = 0.3


class HeldWay:
    """The way onto a mat as the map shows it, held once the robot is near its entry. The navigator asks the
    approach again at the path's end, and walks straight onto what it gets: a way that changed there would be walked
    across whatever changed it. Held, a late change is walked on a planned path (`_onto_mat`)."""

    def __init__(self, way: Callable[[], MatWay], here: Callable[[], tuple[float, float]]) -> None:
        self._way, self._here = way, here
        self._held: MatWay | None = None

    def __call__(self) -> MatWay:
        if self._held is None or math.dist(self._here(), self._held[0]) > HOLD_WAY_WITHIN_M:
            self._held = self._way()
        return self._held


def _entry_pose(way: MatWay) -> tuple[float, float, float]:
    """Where the walk onto the mat starts: the entry, turned to the stance's heading."""
    (x, y), stance = way
    return x, y, stance[2]


# Where to stop at a place (x, y, heading), and whether a stop short of it will do for the work there (asked at
# each stop), for the step after the walk.
WorkPose = Callable[[Place, ExecutionContext], tuple[tuple[float, float, float], Callable[[], bool] | None]]


class LegsAndMap:
    """The legs and the map as navigation uses them (the navigator's `NavBody`), in simulated time. Paths keep off
    the edges of the `mats` (the lidar does not see a 3 mm pad; the layout knows it): walking past the dock's pad, a
    foot could land on its edge."""

    def __init__(
        self,
        legs: Legs,
        localiser: Localiser,
        perception: PerceptionView | None,
        ctx: ExecutionContext,
        mats: tuple[Box, ...] = (),
    ) -> None:
        self._legs = legs
        self._localiser = localiser
        self._perception = perception
        self._ctx = ctx
        self._mats = mats
        self._scans = -1  # the map the costmaps below were grown from
        self._costmaps: dict[tuple[float, bool], Costmap] = {}  # navigation asks for a few each scan

    def pose(self) -> tuple[float, float, float]:
        position, rotation = self._localiser.map_trunk()
        return float(position[0]), float(position[1]), yaw_of(rotation)

    def costmap(self, inflate_m: float, off_mat_edges: bool = True) -> Costmap | None:
        """The map's obstacles grown by `inflate_m`, and (`off_mat_edges`) where a foot would be on a mat's edge."""
        grid = self._perception.feed().map if self._perception is not None else None
        if grid is None:
            return None
        if grid.scans != self._scans:
            self._scans, self._costmaps = grid.scans, {}
        key = (inflate_m, off_mat_edges and bool(self._mats))
        if key not in self._costmaps:
            costmap = Costmap.from_map(grid, inflate_m)
            if key[1]:
                costmap = costmap.also_blocked(near_mat_edges(self._mats, *costmap.centres(), MAT_EDGE_KEEP_OFF_M))
            self._costmaps[key] = costmap
        return self._costmaps[key]

    def drive(self, vx: float, vy: float, yaw_rate: float) -> None:
        self._legs.drive(clip_velocity(Velocity(vx, vy, yaw_rate), self._legs.limits))

    def halt_here(self) -> None:
        self._legs.halt_here()

    def wait(self, seconds: float) -> None:
        self._ctx.wait_sim(seconds)

    def walking(self) -> bool:
        return self._legs.moving

    def fallen(self) -> bool:
        return self._legs.fallen()


class NavigateSkill:
    """The `navigate_to` step, and navigators for the other steps that walk (sharing what stops have taught).
    `work_pose`: where to stop for the next step's work (manipulation knows)."""

    def __init__(
        self,
        parts: BodyParts,
        layout: WorldLayout,
        world: Callable[[], WorldContext],
        publish: Callable[..., Any],
        work_pose: WorkPose,
    ) -> None:
        self._parts = parts
        self._layout = layout
        self._world = world
        self._publish = publish
        self._work_pose = work_pose
        self._stop_drift = StopDrift()  # what stopping a walk does to the pose, learnt by every final approach
        self._navigation: NavigationState | None = None
        self._rested_s = 0.0

    @property
    def rested_s(self) -> float:
        """Simulated seconds this robot's walks have stood partway to let a hot servo cool (`ServoRest`)."""
        return self._rested_s

    def _add_rested(self, seconds: float) -> None:
        self._rested_s += seconds

    @property
    def navigation(self) -> NavigationState | None:
        """The walk under way (path, goal), for the state; None when not navigating."""
        return self._navigation

    def set_navigation(self, navigation: NavigationState | None) -> None:
        self._navigation = navigation

    def end(self) -> None:
        """A step that walked has ended (done, failed or cancelled): the legs stop, the walk is over."""
        self._parts.legs.drive(Velocity())
        self._navigation = None

    def legs_and_map(self, ctx: ExecutionContext) -> LegsAndMap:
        p = self._parts
        mats = tuple(box for box in self._layout.furniture if is_mat(box))
        return LegsAndMap(p.legs, p.localiser, p.perception, ctx, mats)

    def navigator(self, ctx: ExecutionContext) -> Navigator:
        """A navigator on this robot's legs and map, sharing what its stops have taught (`StopDrift`), keeping a
        wider berth from obstacles while it carries something."""
        carrying = self._parts.arm.held is not None
        clearance = CARRYING_CLEARANCE_M if carrying else CLEARANCE_M
        speed = MAX_FORWARD_M_S if carrying else OPEN_M_S
        turn_room = 0.0 if carrying else TURN_ROOM_M
        clock = self._parts.clock
        heat = self._parts.servo_heat
        rest = None if heat is None else ServoRest(heat, ctx.wait_sim, clock.now, self._publish, self._add_rested)
        return Navigator(
            self.legs_and_map(ctx), clock.now, self.set_navigation, self._stop_drift, clearance, speed, turn_room, rest
        )

    def _onto_mat(
        self,
        navigator: Navigator,
        way: Callable[[], MatWay],
        in_reach: Callable[[], bool] | None,
        ctx: ExecutionContext,
    ) -> NavigationReport:
        """To the mat's entry, stopped there and turned to the stance's heading, then straight onto the stance:
        walking on without the stop, the robot came onto the pad still turning, 30-40 degrees aslant. `way` (the
        entry and the stance) is asked again on the walk there: which way has room shows on a map that grows as the
        robot walks (from the start of a tour, before any map, the dock's own way looked open; a box stood on it),
        and held near the entry (`HeldWay`); a change seen there is walked on a planned path."""
        body = self.legs_and_map(ctx)
        held = HeldWay(way, lambda: body.pose()[:2])
        report = navigator.go(lambda _pose: held()[0], lambda: _entry_pose(held()), back_away_m=self.back_away_m(ctx))
        entry, stance = way()
        if math.dist(body.pose()[:2], entry) > WAY_MOVED_M:  # it changed at the last moment
            again = navigator.go(entry, _entry_pose((entry, stance)))
            report.walked_m += again.walked_m
            report.sim_s += again.sim_s
        last = navigator.step_to(stance, good_stop=in_reach)
        report.walked_m += last.walked_m
        report.sim_s += last.sim_s
        report.final_error_m, report.final_heading_error_deg = last.final_error_m, last.final_heading_error_deg
        return report

    def _way_onto_mat(self, pose: PoseGoal, ctx: ExecutionContext) -> tuple[tuple[float, float], float] | None:
        """For a pose on a mat or beside it (a foot would land on its edge): the entry and heading of the way onto
        it nearest the robot, among those clear on the map (`pose_entries`); None for a pose away from mats."""
        mat = mat_under(self._layout, pose.x, pose.y)
        if mat is None:
            return None
        body = self.legs_and_map(ctx)
        ways = roomiest_ways(_grown_map(body), (pose.x, pose.y), pose_entries(mat, pose.x, pose.y, pose.yaw))
        here = body.pose()[:2]
        return min(ways, key=lambda way: math.dist(way[0], here), default=None)

    def _way_onto_place(self, place: Place, stance: tuple[float, float, float], ctx: ExecutionContext) -> MatWay:
        """The entry onto a place on a mat, and the stance there: along the place's own heading (`mat_entry`) where
        that way has the most room on the map; else squarely across the edge with the most room, the stance turned
        to it (a box on the dock's entry: a tour walked into it, and fell, on world seed 22)."""
        assert place.surface is not None
        x, y, yaw = stance
        own = (mat_entry(place), yaw)
        ways = roomiest_ways(
            _grown_map(self.legs_and_map(ctx)), (x, y), [own, *pose_entries(place.surface, x, y, None)]
        )
        entry, heading = ways[0] if ways else own
        return entry, (x, y, heading)

    def _way_onto_pose(self, pose: PoseGoal, first: tuple[tuple[float, float], float], ctx: ExecutionContext) -> MatWay:
        """The way onto a pose on a mat as the map now shows it (`first`, the way found first, if none is clear)."""
        entry, heading = self._way_onto_mat(pose, ctx) or first
        return entry, (pose.x, pose.y, heading)

    def _off_mat(self, navigator: Navigator, goal: tuple[float, float], ctx: ExecutionContext) -> NavigationReport:
        """From a mat (standing on it, bound away from it), straight off it across an edge, turned to that edge on
        the mat first: the edge it faces if its way off has the most room on the map, else the one nearest that
        among those (`_roomiest_ways`). Setting off
        along a planned path, the robot turned on the dock's pad towards its next place and walked off over the pad's
        edge aslant (tours fell leaving the dock on world seeds 0 and 3)."""
        report = NavigationReport()
        body = self.legs_and_map(ctx)
        x, y, yaw = body.pose()
        mat = next((box for box in self._layout.furniture if is_mat(box) and box.contains(x, y)), None)
        if mat is None or mat.contains(*goal, FEET_REACH_M):
            return report
        edges = sorted((k * math.pi / 2 for k in range(-1, 3)), key=lambda h: abs(math.remainder(h - yaw, math.tau)))
        for way_off, heading in roomiest_ways(
            _grown_map(body), (x, y), [(entry_along(mat, x, y, h), h) for h in edges]
        ):
            steps = [(*way_off, heading)]
            if not same_facing(heading, yaw):
                steps.insert(0, (x, y, heading))  # turned where it stands, on the mat
            for step in steps:
                walked = navigator.step_to(step)
                report.walked_m += walked.walked_m
                report.sim_s += walked.sim_s
            return report
        return report

    def navigate_to(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """Walk to a named place: a planned path to the open floor in front of it, then a short precise
        approach."""
        if self._parts.perception is None:
            raise StepFailed("navigation needs the lidar's map, and perception is off in this worker")
        name = self._world().resolve_place(args["target"])
        place = next((p for p in self._layout.places if p.name == name), None)
        pose = parse_pose_goal(args["target"]) if place is None else None
        if place is None and pose is None:
            raise StepFailed(f"unknown place {args['target']!r}")
        self._parts.head.point(0.0, DEFAULT_TILT)  # look ahead and down while walking
        try:
            navigator = self.navigator(ctx)
            leaving = self._off_mat(navigator, (pose.x, pose.y) if pose is not None else place.approach[:2], ctx)
            if pose is not None:  # a pose on the map: walk there, then turn to its heading if it has one
                costmap = self.legs_and_map(ctx).costmap(ROBOT_RADIUS, off_mat_edges=False)
                if costmap is not None and costmap.blocked_at(pose.x, pose.y):
                    raise StepFailed(f"unreachable: ({pose.text()}) is in or against an obstacle on the map")
                first_way = self._way_onto_mat(pose, ctx)
                if first_way is not None:  # squarely onto the mat, as for a place on it
                    report = self._onto_mat(
                        navigator, functools.partial(self._way_onto_pose, pose, first_way, ctx), None, ctx
                    )
                else:
                    final = None if pose.yaw is None else (pose.x, pose.y, pose.yaw)
                    report = navigator.go((pose.x, pose.y), final, back_away_m=self.back_away_m(ctx))
            else:
                assert place is not None
                # whether a stop will do for the work there, by the latest answer (the navigator asks on the way)
                work: list[Callable[[], bool] | None] = [None]

                def work_pose() -> tuple[float, float, float]:
                    stance, work[0] = self._work_pose(place, ctx)
                    return stance

                def in_reach() -> bool:
                    good_stop = work[0]
                    return good_stop is not None and good_stop()

                if place.surface is not None and is_mat(place.surface):
                    report = self._onto_mat(
                        navigator, lambda: self._way_onto_place(place, work_pose(), ctx), in_reach, ctx
                    )
                else:
                    staging = functools.partial(self._staging_for, place, ctx=ctx)
                    report = navigator.go(staging, work_pose, in_reach, self.back_away_m(ctx))
        except NavigationFailed as exc:
            raise StepFailed(str(exc)) from exc
        finally:
            self.end()
        report.walked_m += leaving.walked_m
        report.sim_s += leaving.sim_s
        replans = f", {report.replans} replan{'s' if report.replans != 1 else ''}" if report.replans else ""
        where = f"the {place.name}" if place is not None else f"({pose.text()})" if pose is not None else ""
        self._publish(
            "navigation/arrived",
            f"at {where}",
            place=place.name if place else None,
            goal=pose.text() if pose else None,
            walked_m=report.walked_m,
            replans=report.replans,
            error_m=report.final_error_m,
            sim_s=report.sim_s,
            path=[list(p) for p in report.path],
        )
        return (
            f"at {where}: walked {report.walked_m:.2f} m in {report.sim_s:.0f} s{replans}, "
            f"{report.final_error_m * 100:.1f} cm and {report.final_heading_error_deg:.0f} deg from the goal"
        )

    def _staging_for(
        self, place: Place, work: tuple[float, float, float] | None, ctx: ExecutionContext
    ) -> tuple[float, float]:
        """Where the planned path to a place ends, for the straight walk onto `work` (where the robot will stand):
        the place's staging point, unless the work pose faces the place another way (a stance turned, or round
        another side of the surface, as a chair stood where the feet usually go): then a free point behind it along
        its heading. From the place's staging, the walk onto a stance round the counter's end went straight through
        the chair (world seed 0)."""
        if work is None or same_facing(work[2], place.approach[2]):
            return place.staging
        costmap = self.legs_and_map(ctx).costmap(ROBOT_RADIUS + CLEARANCE_M)
        c, s = math.cos(work[2]), math.sin(work[2])
        for back in WORK_STAGING_BACK_M:
            point = (work[0] - back * c, work[1] - back * s)
            if costmap is None or not costmap.blocked_at(*point):
                return point
        return place.staging

    def back_away_m(self, ctx: ExecutionContext) -> float:
        """How far to walk back before setting off: carrying something held out over a surface, the robot would
        sweep it along the surface as it turns away (the walk backs away first, without stopping)."""
        if self._parts.arm.held is None:
            return 0.0
        return carry_back_away_m(self._layout, self.legs_and_map(ctx).pose())


def roomiest_ways(
    grown_map: Callable[[float], Costmap | None],
    on_mat: tuple[float, float],
    ways: list[tuple[tuple[float, float], float]],
) -> list[tuple[tuple[float, float], float]]:
    """Of `ways` (each a point off a mat and a heading, walked straight between it and `on_mat`), in their order,
    those with the most room on the map, by `MAT_WAY_CLEARANCES_M` (all if there is no map yet). `grown_map(m)`: the
    map with everything grown by `m` beyond the footprint."""
    for extra in MAT_WAY_CLEARANCES_M:
        costmap = grown_map(extra)
        if costmap is None:
            return ways
        beyond = MAT_WAY_FROM_M if extra > 0.0 else 0.0
        clear = [way for way in ways if _clear_line(costmap, way[0], on_mat, beyond_end_m=beyond)]
        if clear:
            return clear
    return []


def _grown_map(body: LegsAndMap) -> Callable[[float], Costmap | None]:
    """The body's map grown by the footprint and a margin (mat edges not blocked: the ways cross them)."""
    return lambda extra_m: body.costmap(ROBOT_RADIUS + extra_m, off_mat_edges=False)


def _clear_line(
    costmap: Costmap, start: tuple[float, float], end: tuple[float, float], beyond_end_m: float = 0.0
) -> bool:
    """Whether the straight walk from `start` to `end` keeps clear of everything on the costmap (but within
    `beyond_end_m` of `end`)."""
    length = math.dist(start, end)
    steps = max(1, math.ceil(length / (costmap.resolution / 2)))
    return not any(
        costmap.blocked_at(start[0] + (end[0] - start[0]) * k / steps, start[1] + (end[1] - start[1]) * k / steps)
        for k in range(steps + 1)
        if length * (1.0 - k / steps) >= beyond_end_m
    )


def carry_back_away_m(layout: WorldLayout, pose: tuple[float, float, float]) -> float:
    """How far a robot carrying something at `pose` must walk back before it turns away: the object, held out
    ahead, would otherwise sweep along the surface in front of it (0 when it is clear already)."""
    back = CARRY_HAND_AHEAD_M + CARRY_CLEARANCE_M - _surface_ahead_m(layout, *pose)
    return back if back >= MIN_STEP_BACK_M else 0.0


def _surface_ahead_m(layout: WorldLayout, x: float, y: float, yaw: float) -> float:
    """How far ahead of (x, y), looking along `yaw`, the nearest raised surface begins (inf if none)."""
    surfaces = [p.surface for p in layout.places if p.surface is not None and p.surface.height >= 0.05]
    return min((box.distance_along(x, y, yaw) for box in surfaces), default=math.inf)
