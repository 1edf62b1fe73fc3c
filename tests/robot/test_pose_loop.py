"""The outer pose loop turns pose errors into velocity corrections, and never chases a stale reference."""

from __future__ import annotations

import math

import pytest

from robot.control.odometry import Pose2D
from robot.control.pose_loop import MAX_POSITION_ERROR_M, PoseLoop, WalkVelocity

LIMITS = WalkVelocity(0.2, 0.1, 1.0)
DT = 0.01


def test_a_robot_falling_behind_is_asked_to_walk_faster() -> None:
    loop = PoseLoop(LIMITS, backward_limit=0.13)
    loop.reset(Pose2D(0.0, 0.0, 0.0))
    command = WalkVelocity(0.1, 0.0, 0.0)
    out = command
    for _ in range(100):  # the robot does not move for 1 s: 0.1 m behind its reference
        out = loop.update(command, Pose2D(0.0, 0.0, 0.0), DT)
    assert out.vx == pytest.approx(0.1 + 0.1, abs=0.01)
    assert out.vy == pytest.approx(0.0) and out.yaw_rate == pytest.approx(0.0)


def test_corrections_are_in_the_robots_frame_and_heading_is_held() -> None:
    loop = PoseLoop(LIMITS, backward_limit=0.13)
    loop.reset(Pose2D(1.0, 2.0, math.pi / 2))  # facing +y
    # the robot slipped 5 cm along world -x (to its right) and turned 0.1 rad clockwise
    out = loop.update(WalkVelocity(0.05, 0.0, 0.0), Pose2D(1.05, 2.0, math.pi / 2 - 0.1), DT)
    assert out.vy > 0.0  # step back to the left
    assert out.yaw_rate == pytest.approx(0.1, abs=0.01)  # turn back counter-clockwise


def test_standing_the_reference_follows_the_estimate_so_a_stop_stays_a_stop() -> None:
    loop = PoseLoop(LIMITS, backward_limit=0.13)
    loop.reset(Pose2D(0.0, 0.0, 0.0))
    zero = WalkVelocity(0.0, 0.0, 0.0)
    assert loop.update(zero, Pose2D(0.3, 0.1, 0.2), DT, stepping=False) == zero
    assert loop.reference == Pose2D(0.3, 0.1, 0.2)
    out = loop.update(WalkVelocity(0.1, 0.0, 0.0), Pose2D(0.3, 0.1, 0.2), DT)
    assert out.vx == pytest.approx(0.1, abs=0.002)  # no walk back to the old origin


def test_after_the_command_stops_the_lag_is_walked_off_then_the_loop_lets_go() -> None:
    loop = PoseLoop(LIMITS, backward_limit=0.13)
    loop.reset(Pose2D(0.0, 0.0, 0.0))
    zero = WalkVelocity(0.0, 0.0, 0.0)
    for _ in range(50):
        loop.update(WalkVelocity(0.1, 0.0, 0.0), Pose2D(0.0, 0.0, 0.0), DT)  # 5 cm behind
    assert loop.update(zero, Pose2D(0.0, 0.0, 0.0), DT).vx > 0.04  # keeps walking to where it was sent
    assert loop.update(zero, Pose2D(0.045, 0.0, 0.0), DT) == zero  # within 2 cm: stop
    loop.release()  # e-stop: no lag is walked off
    assert loop.update(zero, Pose2D(0.3, 0.0, 0.0), DT) == zero


def test_output_is_clipped_and_a_runaway_reference_is_pulled_back() -> None:
    loop = PoseLoop(LIMITS, backward_limit=0.13)
    loop.reset(Pose2D(0.0, 0.0, 0.0))
    for _ in range(1000):  # held in place for 10 s while asked to walk
        out = loop.update(WalkVelocity(0.2, 0.0, 0.0), Pose2D(0.0, 0.0, 0.0), DT)
    assert out.vx == LIMITS.vx
    assert math.hypot(loop.reference.x, loop.reference.y) <= MAX_POSITION_ERROR_M + 1e-9
    out = loop.update(WalkVelocity(-0.2, 0.0, 0.0), Pose2D(0.0, 0.0, 0.0), DT)
    assert out.vx >= -0.13
