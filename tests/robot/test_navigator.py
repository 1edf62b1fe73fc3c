"""The navigator's final approach: it stops on the goal, and settles even when stopping moves the robot."""

from __future__ import annotations

import math

import pytest

from robot.navigation.navigator import MAX_SETTLE_M, SETTLE_GROWTH_M, SETTLED_M, NavigationFailed, Navigator, StopDrift


class DriftingBody:
    """Walks exactly as commanded; each stop slides it `drift_m` to its left, as a walking robot's last two steps
    in place do (more when it carries something)."""

    def __init__(self, drift_m: float) -> None:
        self.x = self.y = self.yaw = 0.0
        self.t = 0.0
        self.velocity = (0.0, 0.0, 0.0)
        self.moving = False
        self.drift_m = drift_m
        self.stops = 0

    def pose(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.yaw)

    def costmap(self, inflate_m: float) -> None:
        return None

    def drive(self, vx: float, vy: float, yaw_rate: float) -> None:
        self.velocity = (vx, vy, yaw_rate)
        if (vx, vy, yaw_rate) != (0.0, 0.0, 0.0):
            self.moving = True
        elif self.moving:
            self.moving = False
            self.stops += 1
            self.x -= math.sin(self.yaw) * self.drift_m
            self.y += math.cos(self.yaw) * self.drift_m

    def halt_here(self) -> None:
        self.drive(0.0, 0.0, 0.0)

    def wait(self, seconds: float) -> None:
        self.t += seconds
        if self.moving:
            vx, vy, w = self.velocity
            c, s = math.cos(self.yaw), math.sin(self.yaw)
            self.x += (c * vx - s * vy) * seconds
            self.y += (s * vx + c * vy) * seconds
            self.yaw += w * seconds

    def walking(self) -> bool:
        return self.moving

    def fallen(self) -> bool:
        return False


def test_a_short_walk_stops_on_the_goal_pose() -> None:
    body = DriftingBody(drift_m=0.0)
    report = Navigator(body, lambda: body.t).step_to((0.3, -0.1, 0.2))
    assert report.final_error_m < 0.02 and report.final_heading_error_deg < 3.0
    assert body.stops == 1 and not body.walking()


def test_when_stopping_drifts_the_robot_it_learns_the_drift_and_stops_that_much_early() -> None:
    body = DriftingBody(drift_m=SETTLED_M + 0.01)
    drift = StopDrift()
    report = Navigator(body, lambda: body.t, stop_drift=drift).step_to((0.3, 0.0, 0.0))
    assert 1 < body.stops <= 3  # the first stop landed outside the tolerance, a later one inside
    assert report.final_error_m < SETTLED_M + SETTLE_GROWTH_M
    assert drift.left > 0.02 and abs(drift.ahead) < 0.01  # it learnt that stopping carries it to its left
    assert body.t < 20.0

    # the next walk, with what the last one learnt, needs fewer stops and comes to rest nearer its goal
    for _ in range(3):
        body.stops = 0
        report = Navigator(body, lambda: body.t, stop_drift=drift).step_to((body.x + 0.3, body.y, 0.0))
    assert body.stops == 1 and report.final_error_m < SETTLED_M


def test_a_stop_the_caller_accepts_ends_the_approach_even_off_the_exact_pose() -> None:
    body = DriftingBody(drift_m=MAX_SETTLE_M - 0.01)  # each stop lands far off: far beyond the first tolerance
    asked: list[tuple[float, float]] = []

    def in_reach() -> bool:  # as the worker judges a work pose: is the object comfortably in the arm's reach?
        asked.append((body.x, body.y))
        return abs(body.y) < 0.08

    report = Navigator(body, lambda: body.t).step_to((0.3, 0.0, 0.0), good_stop=in_reach)
    assert body.stops == 1 and len(asked) == 1
    assert report.final_error_m == pytest.approx(MAX_SETTLE_M - 0.01, abs=0.01)


def test_a_robot_that_cannot_stop_near_the_goal_fails_with_the_reason() -> None:
    body = DriftingBody(drift_m=MAX_SETTLE_M + 0.04)
    with pytest.raises(NavigationFailed, match="could not settle on the goal pose"):
        Navigator(body, lambda: body.t).step_to((0.3, 0.0, 0.0))
    assert not body.walking()
