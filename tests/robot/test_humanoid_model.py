"""humanoid_v1: the OP3 with wrists and grippers, one source for the simulator and the whole-body controller."""

from __future__ import annotations

import math
import os
import tempfile

import mujoco
import numpy as np
import placo
import pytest

from robot.control.gait import load_placo_robot, write_placo_model
from robot.model import humanoid_v1


@pytest.fixture(scope="module")
def robot_model() -> mujoco.MjModel:
    return humanoid_v1.build_robot_spec().compile()


@pytest.fixture(scope="module")
def placo_robot(tmp_path_factory) -> placo.HumanoidRobot:
    return load_placo_robot(write_placo_model(tmp_path_factory.mktemp("placo")))


def test_twenty_four_servos_each_with_xm430_limits(robot_model) -> None:
    assert robot_model.nu == 24 == len(humanoid_v1.JOINT_NAMES)
    for i, name in enumerate(humanoid_v1.JOINT_NAMES):
        actuator = robot_model.actuator(i)
        assert actuator.name == name + "_act"
        if name in humanoid_v1.GRIPPER_JOINTS:
            assert actuator.forcerange[1] == pytest.approx(humanoid_v1.GRIP_FORCE_N / 2)
        else:
            assert actuator.forcerange[1] == humanoid_v1.SERVO_STALL_TORQUE_NM
    assert pytest.approx(46 * 2 * math.pi / 60) == humanoid_v1.SERVO_NO_LOAD_SPEED_RAD_S


def test_every_joint_has_finite_limits(robot_model) -> None:
    limits = humanoid_v1.joint_limits()
    assert set(limits) == set(humanoid_v1.JOINT_NAMES)
    for name, limit in limits.items():
        joint = robot_model.joint(name)
        assert joint.limited[0] or robot_model.jnt_limited[joint.id]
        assert tuple(robot_model.jnt_range[joint.id]) == pytest.approx((limit.lower, limit.upper))
        assert limit.lower < limit.upper


def test_stand_posture_is_inside_the_limits() -> None:
    limits = humanoid_v1.joint_limits()
    for posture in (humanoid_v1.stand_posture(), humanoid_v1.crouch_posture()):
        for name, value in posture.items():
            assert limits[name].lower <= value <= limits[name].upper, name


def test_gripper_opens_56_mm_and_its_fingers_move_together(robot_model) -> None:
    data = mujoco.MjData(robot_model)
    data.qpos[2] = 1.0  # hang in the air: only the gripper matters here
    grip = robot_model.actuator("l_grip_act").id
    for target in (humanoid_v1.FINGER_TRAVEL, 0.0):
        data.ctrl[grip] = target
        for _ in range(500):
            mujoco.mj_step(robot_model, data)
        a = data.qpos[robot_model.joint("l_grip").qposadr[0]]
        b = data.qpos[robot_model.joint("l_grip_mimic").qposadr[0]]
        assert a == pytest.approx(target, abs=2e-3)
        assert b == pytest.approx(a, abs=1e-3)
    left = data.geom("l_finger_a_pad").xpos
    right = data.geom("l_finger_b_pad").xpos
    assert np.linalg.norm(left - right) < 0.01  # closed: the pads touch


def test_placo_model_matches_the_simulated_kinematics(robot_model, placo_robot) -> None:
    """The controller's model and the simulator agree on where the feet and hands are for any joint angles."""
    data = mujoco.MjData(robot_model)
    rng = np.random.default_rng(3)
    for _ in range(5):
        for name in humanoid_v1.JOINT_NAMES:
            limit = humanoid_v1.joint_limits()[name]
            value = rng.uniform(limit.lower, limit.upper)
            data.qpos[robot_model.joint(name).qposadr[0]] = value
            placo_robot.set_joint(name, value)
        data.qpos[:7] = [0, 0, 0, 1, 0, 0, 0]
        mujoco.mj_kinematics(robot_model, data)
        placo_robot.set_T_world_fbase(np.eye(4))
        placo_robot.update_kinematics()
        trunk = placo_robot.get_T_world_frame(humanoid_v1.TRUNK_FRAME)
        for frame in (*humanoid_v1.FOOT_FRAMES.values(), *humanoid_v1.HAND_FRAMES.values()):
            in_trunk = np.linalg.inv(trunk) @ placo_robot.get_T_world_frame(frame)
            site = data.site(frame)
            assert np.allclose(in_trunk[:3, 3], site.xpos - data.xpos[1], atol=1e-6), frame
            assert np.allclose(in_trunk[:3, :3], site.xmat.reshape(3, 3), atol=1e-6), frame


def test_placo_model_has_the_same_mass(robot_model, placo_robot) -> None:
    trunk = robot_model.body(humanoid_v1.TRUNK_BODY).id
    assert placo_robot.total_mass() == pytest.approx(robot_model.body_subtreemass[trunk], rel=1e-6)


def test_standing_the_grippers_hang_well_clear_of_the_floor(robot_model) -> None:
    """An open gripper's lower finger hung 2 cm above the floor, and the walking robot's sway dragged it along:
    standing (and walking), the grippers are closed, which lifts their lowest point 1 cm."""
    data = mujoco.MjData(robot_model)
    for name, value in humanoid_v1.stand_posture().items():
        data.qpos[robot_model.joint(name).qposadr[0]] = value
    mujoco.mj_kinematics(robot_model, data)

    def lowest(body_names: tuple[str, ...]) -> float:
        low = np.inf
        for g in range(robot_model.ngeom):
            if robot_model.body(robot_model.geom_bodyid[g]).name in body_names and robot_model.geom_contype[g]:
                corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
                box = corners * robot_model.geom_size[g]
                world = data.geom_xpos[g] + box @ data.geom_xmat[g].reshape(3, 3).T
                low = min(low, float(world[:, 2].min()))
        return low

    soles = lowest(tuple(humanoid_v1.FOOT_BODIES.values()))
    hands = lowest(tuple(f"{s}_{part}" for s in "lr" for part in ("wrist_link", "finger_a", "finger_b")))
    assert hands - soles > 0.044  # 0.038 with the grippers open


def test_the_placo_model_is_cached_per_user_by_content(tmp_path, monkeypatch) -> None:
    """Every robot process shares one model file (a killed process leaves no directory behind), and a process
    running other code never loads a model written by this one."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    first = write_placo_model()
    assert first.parent == tmp_path / "humanoid" / "placo"
    assert write_placo_model() == first
    assert first.read_text() == humanoid_v1.placo_mjcf()
    monkeypatch.setattr(humanoid_v1, "placo_mjcf", lambda: "<mujoco model='other'/>")
    other = write_placo_model()
    assert other != first and other.read_text() == "<mujoco model='other'/>"
    assert first.read_text() != other.read_text()
    assert sorted(p.name for p in first.parent.iterdir()) == sorted([first.name, other.name])  # no partial files


def test_without_a_writable_cache_the_placo_model_goes_to_the_temporary_directory(tmp_path, monkeypatch) -> None:
    not_a_directory = tmp_path / "cache"
    not_a_directory.write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(not_a_directory))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    path = write_placo_model()
    assert path.parent == tmp_path / "tmp" / f"humanoid-placo-{os.getuid()}"
    assert path.read_text() == humanoid_v1.placo_mjcf()


def test_a_mirrored_arm_posture_puts_the_other_hand_at_the_mirror_image_point(robot_model) -> None:
    """`mirror_arm_joints`, which turns the right hand's tuned moves into the left hand's: for postures across the
    arm's range, the mirrored one puts the other hand (and its fingers) at the point mirrored across the body's
    middle, and mirroring twice gives the posture back."""
    data = mujoco.MjData(robot_model)
    rng = np.random.default_rng(7)
    limits = humanoid_v1.joint_limits()
    arm = ("sho_pitch", "sho_roll", "el", "wrist", "grip")

    def hands(posture: dict[str, float]) -> dict[str, np.ndarray]:
        data.qpos[:] = 0.0
        data.qpos[2], data.qpos[3] = 1.0, 1.0  # upright, in the air, facing +x: the body's middle is y = 0
        for name, value in posture.items():
            data.qpos[robot_model.joint(name).qposadr[0]] = value
        mujoco.mj_kinematics(robot_model, data)
        sites = ("right_hand", "left_hand")
        pads = ("r_finger_a_pad", "r_finger_b_pad", "l_finger_a_pad", "l_finger_b_pad")
        return {s: data.site(s).xpos.copy() for s in sites} | {g: data.geom(g).xpos.copy() for g in pads}

    for _ in range(20):
        right = {f"r_{j}": float(rng.uniform(limits[f"r_{j}"].lower, limits[f"r_{j}"].upper)) for j in arm}
        left = humanoid_v1.mirror_arm_joints(right)
        assert set(left) == {f"l_{j}" for j in arm}
        assert humanoid_v1.mirror_arm_joints(left) == pytest.approx(right)
        assert all(limits[n].lower <= v <= limits[n].upper for n, v in left.items())
        as_right, as_left = hands(right), hands(left)
        flip = np.array([1.0, -1.0, 1.0])
        assert as_left["left_hand"] == pytest.approx(as_right["right_hand"] * flip, abs=1e-6)
        fingers_right = sorted(tuple(as_right[g] * flip) for g in ("r_finger_a_pad", "r_finger_b_pad"))
        fingers_left = sorted(tuple(as_left[g]) for g in ("l_finger_a_pad", "l_finger_b_pad"))
        assert np.array(fingers_left) == pytest.approx(np.array(fingers_right), abs=1e-6)
    with pytest.raises(ValueError, match="not an arm joint"):
        humanoid_v1.mirror_arm_joints({"l_knee": 0.3})
