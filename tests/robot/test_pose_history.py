"""Where a sensor was at a time, between the poses it was seen at."""

from __future__ import annotations

import math

import pytest

from robot.perception.pose_history import PoseHistory


def test_poses_between_two_are_interpolated_across_the_turn_of_the_angle() -> None:
    history = PoseHistory(keep_s=1.0)
    history.add(0.0, (0.0, 0.0, math.pi - 0.1, 0.3))
    history.add(0.1, (0.1, 0.2, -math.pi + 0.1, 0.3))  # turned 0.2 rad through +-pi
    x, y, yaw, height = history.at(0.05)
    assert (x, y, height) == pytest.approx((0.05, 0.1, 0.3))
    assert abs(math.remainder(yaw - math.pi, math.tau)) < 1e-9  # through pi, not back through 0
    assert history.at(0.5) == (0.1, 0.2, -math.pi + 0.1, 0.3)  # after the newest: the newest


def test_a_time_before_what_it_keeps_or_from_another_clock_has_no_answer() -> None:
    history = PoseHistory(keep_s=1.0)
    assert history.at(0.0) is None
    for k in range(30):
        history.add(k * 0.1, (k * 0.1, 0.0, 0.0, 0.0))
    assert history.at(0.5) is None  # older than the second it keeps
    assert history.at(2.5)[0] == pytest.approx(2.5)
    history.add(1.0, (9.0, 9.0, 0.0, 0.0))  # time went back (a restart): what came before is forgotten
    assert history.at(1.0)[0] == 9.0 and history.at(0.95) is None
