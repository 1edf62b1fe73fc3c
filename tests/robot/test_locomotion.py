"""Locomotion in physics: the biped walks on the simulated servos with IMU balance feedback."""

from __future__ import annotations

import numpy as np
import pytest

from robot.control.balance import AnkleBalance
from robot.control.gait import write_placo_model
from robot.control.gait_process import InlineGaitPlanner
from robot.control.locomotion import LocomotionController, Velocity, VelocityLimits, VelocityShaper
from robot.control.walking import WalkPhase
from robot.control.whole_body import WholeBodyIK
from robot.sim.backend import MujocoSimBackend

DT = 0.01


def test_velocity_is_clipped_and_rate_limited() -> None:
    shaper = VelocityShaper(VelocityLimits(vx_forward=0.2, accel=0.3))
    accepted = shaper.set_target(Velocity(vx=5.0, yaw_rate=-9.0))
    assert accepted.vx == 0.2 and accepted.yaw_rate == -VelocityLimits().yaw_rate
    speeds = [shaper.update(DT).vx for _ in range(100)]
    assert np.all(np.diff(speeds) <= 0.3 * DT + 1e-12)  # never faster than the acceleration limit
    assert speeds[-1] == pytest.approx(0.2)
    with pytest.raises(ValueError):
        shaper.set_target(Velocity(vx=float("nan")))


def test_stands_balanced_in_the_walk_ready_posture(layout, scene_model, tmp_path) -> None:
    """Standing still under the locomotion controller (IMU feedback on): upright, on both feet, not drifting."""
    sim = MujocoSimBackend(layout, scene_model)
    model = write_placo_model(tmp_path)
    loco = LocomotionController(
        InlineGaitPlanner(model, DT), WholeBodyIK(model, DT), AnkleBalance(sim.joint_axes()), DT
    )
    sim.reset(loco.stand_targets)
    start = sim.read()
    for _ in range(300):
        m = sim.read()
        sim.write(loco.update(m.imu_quat, m.imu_gyro, loco.stand_targets))
        sim.step(DT)
    end = sim.read()
    assert loco.phase == WalkPhase.STANDING
    assert not end.fallen and end.tilt_deg < 3.0
    assert np.linalg.norm(end.base_position[:2] - start.base_position[:2]) < 0.01
    left, right = end.foot_forces.sum(axis=1)
    assert left > 10.0 and right > 10.0  # weight on both feet
