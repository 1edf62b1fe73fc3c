"""Follows a path with the walking controller's velocity input (pure pursuit): the robot's progress is its nearest
point on the path, and it steers towards the point a lookahead further along, so it stays on the path round
corners instead of cutting them; it turns in place when that point is far off its heading, and slows at the end.

Heading error x 1.0/s clipped to the turn limit, forward speed reduced as the heading error grows, turn in place
beyond ~35 deg. The prototype's go-to-pose gain (1.5/s, lookahead 0.2 m; shared FINDINGS.md) weaved +-15 deg on
straight stretches: a step command acts a step later (~0.45 s), and that delay at 1.5/s leaves little phase margin.
Gain 1.0 with a 0.3 m lookahead walks the same paths about 20% faster (a "bring" on seed 0: 34 s -> 28 s following).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

LOOKAHEAD_M = 0.3
MAX_FORWARD_M_S = 0.15
MAX_TURN_RAD_S = 0.6
HEADING_GAIN = 1.0
TURN_IN_PLACE_RAD = 0.6
ARRIVED_M = 0.08
SLOW_DOWN_M = 0.3
# The fraction of full speed a path ends at: slow, for a stop there; for a path that runs on into a final approach,
# the approach's speed (0.08 of 0.15 m/s), since slowing further only to speed up again costs about half a second.
STOP_END_SPEED = 0.3
RUN_ON_END_SPEED = 0.55
# How far along the path the robot's progress may jump in one update (m): a path that doubles back on itself
# must not be skipped.
PROGRESS_WINDOW_M = 0.5
# Given the map (`blocked_at`), the point steered at is the furthest within the lookahead that the straight way to it
# keeps off the map's grown obstacles, checked every SIGHT_STEP_M beyond SIGHT_NEAR_M of the robot (where it stands
# is where it is), down to MIN_LOOKAHEAD_M. Pure pursuit cuts a corner by up to a third of the lookahead, and a robot
# off its path (it overshot the start of a new one) heads straight for a point round the corner: a patrol's
# shoulder and ankle met a chair that way, and it fell (world seed 2).
SIGHT_STEP_M = 0.05
SIGHT_NEAR_M = 0.1
MIN_LOOKAHEAD_M = 0.05
# Where the lookahead had to be shortened, the robot turns in place beyond this heading error (else
# TURN_IN_PLACE_RAD): walking while it turns sweeps it sideways, towards what shortened it.
CLOSE_TURN_IN_PLACE_RAD = math.radians(15.0)
# Where the lookahead had to be shortened and the robot already heads along the path (within SIDE_STEP_MAX_RAD of
# it), it steps sideways and on towards the point steered at (at SIDE_STEP_M_S) instead of turning in place: it is
# beside its path, in the margin of something. Turning in place there swings the hands, which hang behind the trunk's
# centre, towards what it is beside: a patrol 6 cm off its path along a wall turned 50 deg back towards the path and
# put a finger on the wall (world seed 18).
SIDE_STEP_MAX_RAD = math.radians(30.0)
SIDE_STEP_M_S = 0.05


@dataclass(frozen=True)
class FollowCommand:
    vx: float
    vy: float
    yaw_rate: float
    arrived: bool
    remaining_m: float


class PathFollower:
    def __init__(self, waypoints: list[tuple[float, float]], end_speed: float = STOP_END_SPEED) -> None:
        """`end_speed`: the fraction of full speed to arrive at (STOP_END_SPEED for a stop at the end)."""
        if not waypoints:
            raise ValueError("a path needs at least one waypoint")
        points = [waypoints[0]] + [b for a, b in itertools.pairwise(waypoints) if math.dist(a, b) > 1e-9]
        self.waypoints = points
        self._points = np.asarray(points, dtype=float)
        lengths = np.linalg.norm(np.diff(self._points, axis=0), axis=1) if len(points) > 1 else np.zeros(0)
        self._arc = np.concatenate([[0.0], np.cumsum(lengths)])
        self.length = float(self._arc[-1])
        self.progress = 0.0  # arc length of the robot's nearest point on the path
        self.end_speed = end_speed

    def point_at(self, s: float) -> tuple[float, float]:
        """The path's point `s` metres from its start (clamped to its ends)."""
        s = min(max(s, 0.0), self.length)
        k = int(np.searchsorted(self._arc, s, side="right")) - 1
        k = min(k, len(self._points) - 2) if len(self._points) > 1 else 0
        if len(self._points) == 1:
            return (float(self._points[0, 0]), float(self._points[0, 1]))
        t = (s - self._arc[k]) / max(self._arc[k + 1] - self._arc[k], 1e-9)
        p = self._points[k] + t * (self._points[k + 1] - self._points[k])
        return (float(p[0]), float(p[1]))

    def _nearest_progress(self, x: float, y: float) -> float:
        best_s, best_d = self.progress, math.inf
        for k in range(len(self._points) - 1):
            a, b = self._points[k], self._points[k + 1]
            if self._arc[k] > self.progress + PROGRESS_WINDOW_M or self._arc[k + 1] < self.progress:
                continue
            ab = b - a
            t = float(np.clip(np.dot([x - a[0], y - a[1]], ab) / max(float(np.dot(ab, ab)), 1e-12), 0.0, 1.0))
            s = self._arc[k] + t * float(np.linalg.norm(ab))
            if s > self.progress + PROGRESS_WINDOW_M:
                continue
            d = math.dist((x, y), (a[0] + t * ab[0], a[1] + t * ab[1]))
            if d < best_d:
                best_s, best_d = s, d
        return max(self.progress, best_s)

    def update(
        self, x: float, y: float, yaw: float, blocked_at: Callable[[float, float], bool] | None = None
    ) -> FollowCommand:
        """The velocity command for a robot at (x, y) heading `yaw` (world frame); `blocked_at`: where the map has
        no room for the robot (see SIGHT_STEP_M), if known."""
        self.progress = self._nearest_progress(x, y)
        goal = self.point_at(self.length)
        remaining = (self.length - self.progress) + math.dist((x, y), self.point_at(self.progress))
        if self.length - self.progress < LOOKAHEAD_M and math.dist((x, y), goal) < ARRIVED_M:
            return FollowCommand(0.0, 0.0, 0.0, True, 0.0)
        lookahead = self._lookahead(x, y, blocked_at)
        tx, ty = self.point_at(self.progress + lookahead)
        if math.dist((x, y), (tx, ty)) < 1e-6:
            tx, ty = goal
        error = math.remainder(math.atan2(ty - y, tx - x) - yaw, math.tau)
        yaw_rate = max(-MAX_TURN_RAD_S, min(MAX_TURN_RAD_S, HEADING_GAIN * error))
        if lookahead < LOOKAHEAD_M and abs(error) > CLOSE_TURN_IN_PLACE_RAD:
            along = self._heading_along(self.progress)
            along_error = math.remainder(along - yaw, math.tau)
            if abs(along_error) <= SIDE_STEP_MAX_RAD:
                return self._side_step(x, y, yaw, (tx, ty), along_error, remaining)
        if abs(error) > (TURN_IN_PLACE_RAD if lookahead >= LOOKAHEAD_M else CLOSE_TURN_IN_PLACE_RAD):
            return FollowCommand(0.0, 0.0, yaw_rate, False, remaining)
        speed = MAX_FORWARD_M_S * min(1.0, remaining / SLOW_DOWN_M + self.end_speed) * math.cos(error) ** 2
        return FollowCommand(speed, 0.0, yaw_rate, False, remaining)

    def _heading_along(self, s: float) -> float:
        """The path's heading at `s` (over the next lookahead, so a corner just passed does not count)."""
        ax, ay = self.point_at(s)
        bx, by = self.point_at(s + LOOKAHEAD_M)
        if math.hypot(bx - ax, by - ay) < 1e-9:
            ax, ay = self.point_at(s - LOOKAHEAD_M)
            bx, by = self.point_at(s)
        return math.atan2(by - ay, bx - ax)

    @staticmethod
    def _side_step(
        x: float, y: float, yaw: float, target: tuple[float, float], along_error: float, remaining: float
    ) -> FollowCommand:
        """Step straight towards `target` at SIDE_STEP_M_S, turning only to line up with the path."""
        dx, dy = target[0] - x, target[1] - y
        c, s = math.cos(yaw), math.sin(yaw)
        ahead, left = c * dx + s * dy, -s * dx + c * dy
        norm = math.hypot(ahead, left) or 1.0
        yaw_rate = max(-MAX_TURN_RAD_S, min(MAX_TURN_RAD_S, HEADING_GAIN * along_error))
        return FollowCommand(SIDE_STEP_M_S * ahead / norm, SIDE_STEP_M_S * left / norm, yaw_rate, False, remaining)

    def _lookahead(self, x: float, y: float, blocked_at: Callable[[float, float], bool] | None) -> float:
        """How far along the path to steer at: LOOKAHEAD_M, shortened until the straight way there is clear."""
        lookahead = LOOKAHEAD_M
        while blocked_at is not None and lookahead > MIN_LOOKAHEAD_M + 1e-9:
            if _clear_way((x, y), self.point_at(self.progress + lookahead), blocked_at):
                break
            lookahead -= SIGHT_STEP_M
        return lookahead


def _clear_way(
    start: tuple[float, float], end: tuple[float, float], blocked_at: Callable[[float, float], bool]
) -> bool:
    """Whether the straight way from `start` to `end` is off the map's blocked cells beyond SIGHT_NEAR_M."""
    length = math.dist(start, end)
    for d in np.arange(SIGHT_NEAR_M, length + 1e-9, SIGHT_STEP_M):
        f = d / length
        if blocked_at(start[0] + f * (end[0] - start[0]), start[1] + f * (end[1] - start[1])):
            return False
    return True
