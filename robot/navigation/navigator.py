"""`navigate_to`: plan a path on the occupancy map, walk it through the legs' velocity input, replan when the map
shows it blocked, and finish with a slow, precise approach to the goal pose.

Two goals per place: the *staging* point on open floor in front of it (reached along a planned path, keeping the
robot's footprint plus a margin clear of everything) and the *approach* pose at the surface (reached from the
staging point by a short straight walk, where the margin no longer applies). Every failure says why: no path
("path blocked"), no progress ("stuck"), a fall.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from robot.interface import NavigationState
from robot.model.world import NAV_CLEARANCE_M, ROBOT_RADIUS
from robot.navigation.costmap import Costmap
from robot.navigation.follower import PathFollower
from robot.navigation.grid_planner import astar, nearest_free, simplify

CLEARANCE_M = NAV_CLEARANCE_M  # beyond the footprint: a walking robot sways, and its arms reach past its feet
CONTROL_PERIOD_S = 0.1
REPLAN_CHECK_S = 0.5
BLOCKED_WAIT_S = 3.0  # a path found blocked is retried for this long before giving up
STUCK_S = 20.0
# Final approach (gains of the closed-loop walking prototype's go-to-pose, shared FINDINGS.md)
APPROACH_GAIN = (0.8, 0.8, 1.2)
APPROACH_LIMIT = (0.08, 0.05, 0.6)
ARRIVED_M = 0.02
ARRIVED_RAD = math.radians(3.0)
# Where the robot may come to rest: the two steps in place that stop the walk move it up to a few cm.
SETTLED_M = 0.035
SETTLED_RAD = math.radians(5.0)
SETTLE_GROWTH_M = 0.015
MAX_SETTLE_M = 0.08
APPROACH_TIMEOUT_S = 30.0
MIN_WALK_S = 1.0


class NavigationFailed(Exception):
    """A precise reason: 'path blocked ...', 'stuck ...', 'fell ...'."""


class NavBody(Protocol):
    def pose(self) -> tuple[float, float, float]:
        """Where the robot believes it is, in the map frame: x, y, heading."""

    def costmap(self, inflate_m: float) -> Costmap | None:
        """The latest map with its obstacles grown by `inflate_m` (None before the first map)."""

    def drive(self, vx: float, vy: float, yaw_rate: float) -> None:
        """Velocity for the legs, in the robot's frame (a deadman: repeat it every control period)."""

    def halt_here(self) -> None:
        """Stop where the robot is, without first walking off the lag between where the legs were asked to be and
        where they are (the final approach closes that loop itself; walking it off overshoots the goal)."""

    def wait(self, seconds: float) -> None:
        """Let this much simulated time pass (raises when the plan is cancelled)."""

    def walking(self) -> bool: ...

    def fallen(self) -> bool: ...


@dataclass
class NavigationReport:
    walked_m: float = 0.0  # along the planned paths actually followed, plus the final approach
    replans: int = 0
    sim_s: float = 0.0
    final_error_m: float = 0.0
    final_heading_error_deg: float = 0.0
    path: tuple[tuple[float, float], ...] = ()


def plan_path(costmap: Costmap, start: tuple[float, float], goal: tuple[float, float]) -> list[tuple[float, float]]:
    """A path of points from start to goal on the costmap (ends moved to the nearest free cells), or raise."""
    ends = nearest_free(costmap.blocked, costmap.cell(*start)), nearest_free(costmap.blocked, costmap.cell(*goal))
    if None in ends:
        raise NavigationFailed(f"path blocked: no free space near ({goal[0]:.2f}, {goal[1]:.2f})")
    cells = astar(costmap.blocked, *ends)  # type: ignore[arg-type]
    if cells is None:
        raise NavigationFailed(f"path blocked: no path to ({goal[0]:.2f}, {goal[1]:.2f}) on the map")
    points = [start] + [costmap.centre(i, j) for i, j in cells[1:-1]] + [goal]
    return simplify(points, costmap.blocked_at, costmap.resolution / 2)


def _path_blocked(costmap: Costmap, follower: PathFollower) -> bool:
    """Whether the rest of the path (from the robot's progress on) crosses a blocked cell. A robot standing in an
    obstacle's grown margin (beside furniture) starts its path there: that first stretch does not count, or every
    new path would be found blocked at once."""
    s = follower.progress + 0.15  # the cells right under the robot may be grown over by a nearby obstacle
    if costmap.blocked_at(*follower.point_at(follower.progress)):
        while s < follower.length - 0.1 and costmap.blocked_at(*follower.point_at(s)):
            s += costmap.resolution / 2
    while s < follower.length - 0.1:
        if costmap.blocked_at(*follower.point_at(s)):
            return True
        s += costmap.resolution / 2
    return False


@dataclass
class StopDrift:
    """How far the robot still moves while it stops (its own frame, m): the two steps in place that end a walk carry
    it on a few cm, mostly the same way each time (measured: 2-3 cm to the left, 0-2 cm back). Learnt from every
    stop of the final approach, so the next one stops that much early and comes to rest on the goal."""

    ahead: float = 0.0
    left: float = 0.0

    def learn(self, ahead: float, left: float) -> None:
        """Blend in one stop's measured drift (a stop that had to take extra steps counts no more than MAX_DRIFT_M)."""
        size = math.hypot(ahead, left)
        if size > MAX_DRIFT_M:
            ahead, left = ahead * MAX_DRIFT_M / size, left * MAX_DRIFT_M / size
        self.ahead += DRIFT_LEARNING_RATE * (ahead - self.ahead)
        self.left += DRIFT_LEARNING_RATE * (left - self.left)


MAX_DRIFT_M = 0.05
DRIFT_LEARNING_RATE = 0.5


class Navigator:
    def __init__(self, body: NavBody, sim_time: Callable[[], float],
                 on_update: Callable[[NavigationState], None] | None = None,
                 stop_drift: StopDrift | None = None) -> None:  # fmt: skip
        """`stop_drift` is shared by the navigations of one robot (what one stop taught serves the next)."""
        self.body = body
        self.stop_drift = stop_drift if stop_drift is not None else StopDrift()
        self._now = sim_time
        self._on_update = on_update or (lambda state: None)
        self._goal: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def go(self, staging: tuple[float, float],
           approach: tuple[float, float, float] | Callable[[], tuple[float, float, float]] | None = None,
           good_stop: Callable[[], bool] | None = None) -> NavigationReport:  # fmt: skip
        """Walk a planned path to `staging`, then straight onto the `approach` pose if one is given (a callable is
        asked at the staging point: what the robot sees from there may decide where it stands). `good_stop` is the
        caller's own judgement of where the robot came to rest (a work pose: the object in the arm's reach): a stop
        it accepts ends the approach, however far from the exact pose."""
        report = NavigationReport()
        started = self._now()
        self._goal = approach if isinstance(approach, tuple) else (*staging, self.body.pose()[2])
        # walking on into the approach, without stopping at the staging point, saves a stop and a restart
        self._follow_path(staging, report, stop_at_end=approach is None)
        if callable(approach):
            approach = approach()
            self._goal = approach
        if approach is not None:
            self._on_update(NavigationState(self._goal, report.path, report.replans, "approaching"))
            self._approach(approach, report, good_stop=good_stop)
        self._on_update(NavigationState(self._goal, report.path, report.replans, "arrived"))
        x, y, yaw = self.body.pose()
        goal = approach if approach is not None else (*staging, yaw)
        report.final_error_m = math.dist((x, y), goal[:2])
        report.final_heading_error_deg = math.degrees(abs(math.remainder(yaw - goal[2], math.tau)))
        report.sim_s = self._now() - started
        return report

    def step_to(self, goal: tuple[float, float, float], settle_m: float = SETTLED_M,
                good_stop: Callable[[], bool] | None = None) -> NavigationReport:  # fmt: skip
        """A short straight walk onto a pose, without planning (adjusting the stance at a counter: from right in
        front of furniture the map puts the robot inside the furniture's grown footprint, where A* cannot start)."""
        report = NavigationReport()
        started = self._now()
        self._goal = goal
        self._on_update(NavigationState(goal, (), 0, "approaching"))
        self._approach(goal, report, settle_m, good_stop)
        self._on_update(NavigationState(goal, (), 0, "arrived"))
        x, y, yaw = self.body.pose()
        report.final_error_m = math.dist((x, y), goal[:2])
        report.final_heading_error_deg = math.degrees(abs(math.remainder(yaw - goal[2], math.tau)))
        report.sim_s = self._now() - started
        return report

    def _costmap(self) -> Costmap:
        costmap = self.body.costmap(ROBOT_RADIUS + CLEARANCE_M)
        if costmap is None:
            raise NavigationFailed("no map yet: the lidar has not produced one")
        return costmap

    def _follow_path(self, goal: tuple[float, float], report: NavigationReport, stop_at_end: bool = True) -> None:
        body = self.body
        x, y, _ = body.pose()
        path = self._plan_or_wait((x, y), goal)
        report.path = tuple(path)
        self._on_update(NavigationState(self._goal, report.path, report.replans))
        follower = PathFollower(path)
        last_check = best_time = self._now()
        best_remaining = math.inf
        while True:
            self._check_fall()
            x, y, yaw = body.pose()
            command = follower.update(x, y, yaw)
            if command.arrived:
                report.walked_m += follower.progress
                break
            now = self._now()
            if command.remaining_m < best_remaining - 0.05:
                best_remaining, best_time = command.remaining_m, now
            elif now - best_time > STUCK_S:
                self._stop()
                left = command.remaining_m
                raise NavigationFailed(f"stuck: no progress for {STUCK_S:.0f} s, {left:.2f} m from the goal")
            if now - last_check >= REPLAN_CHECK_S:
                last_check = now
                if _path_blocked(self._costmap(), follower):
                    report.walked_m += follower.progress
                    path = self._replan((x, y), goal)
                    report.replans += 1
                    report.path = tuple(path)
                    self._on_update(NavigationState(self._goal, report.path, report.replans))
                    follower = PathFollower(path)
                    best_remaining, best_time = math.inf, self._now()
                    continue
            body.drive(command.vx, command.vy, command.yaw_rate)
            body.wait(CONTROL_PERIOD_S)
        if stop_at_end:
            self._stop()

    def _replan(self, start: tuple[float, float], goal: tuple[float, float]) -> list[tuple[float, float]]:
        """A new path, found without breaking stride when the map has one (a stop and a restart cost about 3 s);
        otherwise stop and wait for the way to clear."""
        try:
            return plan_path(self._costmap(), start, goal)
        except NavigationFailed:
            self._stop()
            return self._plan_or_wait(start, goal)

    def _plan_or_wait(self, start: tuple[float, float], goal: tuple[float, float]) -> list[tuple[float, float]]:
        """A path now, or after waiting a little for the way to clear (a person passing), or raise."""
        deadline = self._now() + BLOCKED_WAIT_S
        while True:
            try:
                return plan_path(self._costmap(), start, goal)
            except NavigationFailed:
                if self._now() >= deadline:
                    raise
                self.body.wait(0.5)

    def _approach(self, goal: tuple[float, float, float], report: NavigationReport,
                  settle_m: float = SETTLED_M, good_stop: Callable[[], bool] | None = None) -> None:  # fmt: skip
        """Walk the last stretch slowly and stop on the goal pose. Stopping takes two steps in place, which move the
        robot a few cm (more when it carries something): once stopped within `settle_m` and SETTLED_RAD, or where
        `good_stop` accepts, it has arrived; further off, it walks again, and each retry accepts SETTLE_GROWTH_M more
        (stopping drifts about the same each time, so insisting would never end). A retry costs 3-4 s."""
        body = self.body
        kx, ky, kw = APPROACH_GAIN
        lx, ly, lw = APPROACH_LIMIT
        deadline = self._now() + APPROACH_TIMEOUT_S
        report.walked_m += math.dist(body.pose()[:2], goal[:2])
        tolerance = settle_m
        drift = self.stop_drift
        walked_since = -math.inf  # a retry walks at least MIN_WALK_S: a stop from standing would teach nothing
        while self._now() < deadline:
            self._check_fall()
            ex, ey, heading_error = _pose_error(body.pose(), goal)
            # aim short of the goal by what the stop will still carry the robot
            ax, ay = ex - drift.ahead, ey - drift.left
            aimed = math.hypot(ax, ay) < ARRIVED_M and abs(heading_error) < ARRIVED_RAD
            if aimed and self._now() - walked_since >= MIN_WALK_S:
                self._stop(promptly=True)
                sx, sy, heading_error = _pose_error(body.pose(), goal)
                drift.learn(ex - sx, ey - sy)
                if math.hypot(sx, sy) < tolerance and abs(heading_error) < SETTLED_RAD:
                    return
                if good_stop is not None and abs(heading_error) < SETTLED_RAD and good_stop():
                    return
                tolerance = min(tolerance + SETTLE_GROWTH_M, MAX_SETTLE_M)
                walked_since = self._now()
                ex, ey = sx, sy
                ax, ay = ex - drift.ahead, ey - drift.left
            body.drive(_clip(kx * ax, lx), _clip(ky * ay, ly), _clip(kw * heading_error, lw))
            body.wait(CONTROL_PERIOD_S)
        self._stop()
        error = math.dist(body.pose()[:2], goal[:2])
        if error > MAX_SETTLE_M:
            raise NavigationFailed(f"stuck: could not settle on the goal pose ({error * 100:.0f} cm off)")

    def _stop(self, promptly: bool = False) -> None:
        body = self.body
        if promptly:
            body.halt_here()
        for _ in range(100):
            if not body.walking():
                return
            body.drive(0.0, 0.0, 0.0)
            body.wait(CONTROL_PERIOD_S)

    def _check_fall(self) -> None:
        if self.body.fallen():
            raise NavigationFailed("fell while walking")


def _pose_error(pose: tuple[float, float, float], goal: tuple[float, float, float]) -> tuple[float, float, float]:
    """The goal relative to the robot: ahead, to the left (m), and the heading error (rad)."""
    x, y, yaw = pose
    dx, dy = goal[0] - x, goal[1] - y
    c, s = math.cos(yaw), math.sin(yaw)
    return c * dx + s * dy, -s * dx + c * dy, math.remainder(goal[2] - yaw, math.tau)


def _clip(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))
