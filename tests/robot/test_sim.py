from __future__ import annotations

import numpy as np
import pytest

from robot.model import humanoid_v1, op3
from robot.sim.backend import MujocoSimBackend


def test_physics_runs_at_500_hz(scene_model) -> None:
    assert scene_model.opt.timestep == 0.002


def test_robot_stands_still_holding_its_posture(layout, scene_model) -> None:
    sim = MujocoSimBackend(layout, scene_model)
    start = sim.read()
    for _ in range(500):  # 5 s at 100 Hz
        sim.write(sim.stand_targets())
        sim.step(0.01)
    end = sim.read()
    assert end.sim_time_s == pytest.approx(5.0)
    assert not end.fallen
    assert end.tilt_deg < 3.0
    assert abs(end.base_position[2] - op3.STAND_TRUNK_HEIGHT) < 0.01
    assert np.sum(end.foot_forces) == pytest.approx(9.81 * sum_robot_mass(scene_model), rel=0.05)
    assert np.linalg.norm(end.base_position[:2] - start.base_position[:2]) < 0.02
    assert np.max(np.abs(end.joint_positions - sim.stand_targets())) < 0.05


def sum_robot_mass(model) -> float:
    return float(model.body_subtreemass[model.body(humanoid_v1.TRUNK_BODY).id])


def test_imu_reads_the_trunk_orientation_and_rate(layout, scene_model) -> None:
    sim = MujocoSimBackend(layout, scene_model)
    sim.step(0.5)
    m = sim.read()
    assert np.allclose(
        np.abs(m.imu_quat), np.abs(m.base_quat), atol=1e-4
    )  # the IMU is in the trunk (one physics step old)
    assert np.linalg.norm(m.imu_gyro) < 0.2  # standing still


def test_objects_rest_on_the_counter(layout, scene_model) -> None:
    sim = MujocoSimBackend(layout, scene_model)
    sim.step(2.0)
    for obj in layout.objects:
        x, y, z = sim.object_positions()[obj.name]
        assert abs(x - obj.position[0]) < 0.01 and abs(y - obj.position[1]) < 0.01
        assert abs(z - obj.position[2]) < 0.01


def test_fall_is_detected_when_the_trunk_tips_over(layout, scene_model) -> None:
    sim = MujocoSimBackend(layout, scene_model)
    sim.data.qpos[3:7] = [np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0]  # rolled 90 degrees
    assert sim.read().fallen
