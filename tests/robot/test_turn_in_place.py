"""Turning in place for a task (facing a place on a tour, looking round for an object): a turn blocked by an arm
against the furniture the robot faces backs off and turns on; one still blocked fails with the reason."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.control.locomotion import Velocity
from robot.planning.executor import StepFailed
from robot.skills.detect import BACK_OFF_M, Looking


class PinnedRobot:
    """Legs, head, localiser and clock of a robot whose turn is held while it stands within `pinned_m` of where it
    started (its arm against the counter it faces); it walks and turns as commanded otherwise."""

    def __init__(self, pinned_m: float) -> None:
        self.x = self.y = self.yaw = self.t = 0.0
        self.velocity = Velocity()
        self.pinned_m = pinned_m
        self.lowest_x = 0.0

    # Legs
    limits = None

    @property
    def moving(self) -> bool:
        return self.velocity != Velocity()

    def drive(self, velocity: Velocity) -> None:
        self.velocity = velocity

    def halt_here(self) -> None:
        self.velocity = Velocity()

    # Head
    target = (0.0, 0.0)
    at_target = True

    def point(self, pan: float, tilt: float) -> tuple[float, float]:
        return (pan, tilt)

    # Localiser
    def map_trunk(self) -> tuple[np.ndarray, np.ndarray]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([self.x, self.y, 0.27]), np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    # ExecutionContext
    def wait_sim(self, seconds: float) -> None:
        self.t += seconds
        v = self.velocity
        self.x += (math.cos(self.yaw) * v.vx - math.sin(self.yaw) * v.vy) * seconds
        self.y += (math.sin(self.yaw) * v.vx + math.cos(self.yaw) * v.vy) * seconds
        self.lowest_x = min(self.lowest_x, self.x)
        if math.hypot(self.x, self.y) >= self.pinned_m:
            self.yaw += v.yaw_rate * seconds


def _looking(robot: PinnedRobot) -> Looking:
    return Looking(robot, robot, robot, None, lambda: robot.t, robot)  # type: ignore[arg-type]


def test_a_turn_blocked_by_what_the_robot_faces_backs_off_and_turns_on() -> None:
    robot = PinnedRobot(pinned_m=0.05)
    _looking(robot).turn_in_place(math.radians(60))
    assert robot.yaw == pytest.approx(math.radians(60), abs=0.15)
    assert robot.lowest_x == pytest.approx(-BACK_OFF_M, abs=0.01)  # straight back, away from what it faced
    assert not robot.moving


def test_a_free_turn_does_not_back_off() -> None:
    robot = PinnedRobot(pinned_m=0.0)
    _looking(robot).turn_in_place(math.radians(-60))
    assert robot.yaw == pytest.approx(math.radians(-60), abs=0.15)
    assert robot.lowest_x == 0.0


def test_a_turn_still_blocked_after_backing_off_fails_with_the_reason() -> None:
    robot = PinnedRobot(pinned_m=1.0)
    with pytest.raises(StepFailed, match="could not turn in place"):
        _looking(robot).turn_in_place(math.radians(60))
    assert not robot.moving
