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


def test_the_physics_model_leaves_out_the_drawn_meshes_and_moves_exactly_as_the_drawn_one(layout) -> None:
    """The robot process simulates without the detailed meshes (0.7 s and ~340 MB less to start); the cameras and
    3D views draw them from their own models. Nothing may depend on them: same bodies, same motion to the bit."""
    import mujoco

    from robot.model.scene import build_scene

    drawn, physics = build_scene(layout), build_scene(layout, drawn=False)
    detailed = humanoid_v1.DETAILED_MESH_GROUP
    assert _geoms_in(drawn, detailed) > 0 and _geoms_in(physics, detailed) == 0
    assert physics.nmeshface < drawn.nmeshface / 20
    assert (physics.nq, physics.nv, physics.nu, physics.nbody) == (drawn.nq, drawn.nv, drawn.nu, drawn.nbody)
    runs = []
    for model in (drawn, physics):
        data = mujoco.MjData(model)
        rng = np.random.default_rng(0)
        for _ in range(1500):  # 3 s of random servo targets: the robot flails, falls and hits the floor
            data.ctrl[:] = rng.normal(0.0, 0.4, model.nu)
            mujoco.mj_step(model, data)
        runs.append(data.qpos.copy())
    assert np.array_equal(runs[0], runs[1])


def _geoms_in(model, group: int) -> int:
    return sum(int(model.geom_group[g]) == group for g in range(model.ngeom))
