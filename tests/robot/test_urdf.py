"""The URDF generated from the MuJoCo model: read back with a URDF library (yourdfpy), it has the simulator's
joints and limits, its forward kinematics puts every link where MuJoCo puts the body, and its meshes travel
inside the file."""

from __future__ import annotations

import io
import re

import collada
import mujoco
import numpy as np
import pytest
import yourdfpy

from robot.model import humanoid_v1
from robot.model.collada import read_data_uri
from robot.model.urdf import quat_to_rpy, robot_urdf, subtree


@pytest.fixture(scope="module")
def urdf_text() -> str:
    return robot_urdf()


@pytest.fixture(scope="module")
def urdf(urdf_text: str) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(
        io.StringIO(urdf_text), load_meshes=False, build_collision_scene_graph=False, load_collision_meshes=False
    )


def _robot_joints(model: mujoco.MjModel) -> list[int]:
    bodies = set(subtree(model, model.body(humanoid_v1.TRUNK_BODY).id))
    return [
        j
        for j in range(model.njnt)
        if model.jnt_bodyid[j] in bodies and model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
    ]


def test_joints_and_limits_are_the_simulators(urdf: yourdfpy.URDF, scene_model: mujoco.MjModel) -> None:
    assert urdf.validate() and urdf.base_link == humanoid_v1.TRUNK_BODY
    joints = _robot_joints(scene_model)
    assert {n for n, j in urdf.joint_map.items() if j.type != "fixed"} == {scene_model.joint(j).name for j in joints}
    # every servo is a joint a JointStates message can drive; the second finger follows the first
    assert set(urdf.actuated_joint_names) == set(humanoid_v1.JOINT_NAMES)
    for j in joints:
        joint = urdf.joint_map[scene_model.joint(j).name]
        hinge = scene_model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
        assert joint.type == ("revolute" if hinge else "prismatic")
        assert (joint.limit.lower, joint.limit.upper) == pytest.approx(tuple(scene_model.jnt_range[j]), abs=1e-9)
        assert np.allclose(joint.axis, scene_model.jnt_axis[j])
        assert joint.limit.effort > 0 and joint.limit.velocity > 0
    assert urdf.joint_map["l_grip_mimic"].mimic.joint == "l_grip"
    assert urdf.joint_map["head_pan"].limit.effort == pytest.approx(humanoid_v1.SERVO_STALL_TORQUE_NM)


def test_inertials_are_the_bodies(urdf: yourdfpy.URDF, scene_model: mujoco.MjModel) -> None:
    for b in subtree(scene_model, scene_model.body(humanoid_v1.TRUNK_BODY).id):
        inertial = urdf.link_map[scene_model.body(b).name].inertial
        assert inertial.mass == pytest.approx(scene_model.body_mass[b], rel=1e-6)
        assert np.allclose(inertial.origin[:3, 3], scene_model.body_ipos[b], atol=1e-9)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, scene_model.body_iquat[b])
        rot = rot.reshape(3, 3)
        expected = rot @ np.diag(scene_model.body_inertia[b]) @ rot.T  # in the body frame
        assert np.allclose(
            inertial.origin[:3, :3] @ inertial.inertia @ inertial.origin[:3, :3].T,
            expected,
            atol=1e-9 + 1e-6 * np.abs(expected).max(),
        )


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_forward_kinematics_match_mujoco(urdf: yourdfpy.URDF, scene_model: mujoco.MjModel, seed: int) -> None:
    """Random poses within the limits (and the standing one): each link, seen from the trunk, is where MuJoCo puts
    the body of its name."""
    model = scene_model
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    qpos = model.qpos0.copy()
    joints = _robot_joints(model)
    for j in joints:
        low, high = model.jnt_range[j]
        qpos[model.jnt_qposadr[j]] = rng.uniform(low, high) if seed else 0.0
    for j, (followed, multiplier, offset) in (
        (model.joint(n).id, (model.joint(n[:-6]).id, 1.0, 0.0)) for n in ("l_grip_mimic", "r_grip_mimic")
    ):
        qpos[model.jnt_qposadr[j]] = offset + multiplier * qpos[model.jnt_qposadr[followed]]
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    urdf.update_cfg({n: qpos[model.jnt_qposadr[model.joint(n).id]] for n in urdf.actuated_joint_names})
    trunk = model.body(humanoid_v1.TRUNK_BODY).id
    world_to_trunk = np.linalg.inv(_pose(data.xpos[trunk], data.xmat[trunk]))
    for b in subtree(model, trunk):
        expected = world_to_trunk @ _pose(data.xpos[b], data.xmat[b])
        got = urdf.get_transform(model.body(b).name, humanoid_v1.TRUNK_BODY)
        assert np.allclose(got, expected, atol=1e-9), model.body(b).name
    # the camera's optical frame looks where the head does (its z along the head's x), image y down
    camera = urdf.get_transform(humanoid_v1.HEAD_CAMERA, humanoid_v1.HEAD_CAMERA_BODY)
    assert np.allclose(camera[:3, 2], [1, 0, 0], atol=1e-7) and np.allclose(camera[:3, 1], [0, 0, -1], atol=1e-7)
    assert np.allclose(camera[:3, 3], humanoid_v1.CAMERA_POS)


def _pose(position: np.ndarray, xmat: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = np.asarray(xmat).reshape(3, 3)
    out[:3, 3] = position
    return out


def test_the_file_carries_its_meshes_and_names_no_path_of_this_machine(urdf_text: str, scene_model) -> None:
    assert "file:" not in urdf_text and "package:" not in urdf_text and "/home" not in urdf_text
    uris = set(re.findall(r'filename="([^"]+)"', urdf_text))
    assert len(uris) == sum(
        1
        for g in range(scene_model.ngeom)
        if scene_model.geom_group[g] == 3 and scene_model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
    )
    faces = {int(scene_model.mesh_facenum[m]) for m in range(scene_model.nmesh)}
    for uri in uris:
        media_type, data = read_data_uri(uri)
        assert media_type == "model/vnd.collada+xml"
        doc = collada.Collada(io.BytesIO(data))
        assert doc.assetInfo.upaxis == collada.asset.UP_AXIS.Z_UP  # drawn upright whatever the viewer's default
        triangles = doc.geometries[0].primitives[0]
        assert len(triangles) in faces
        corners = triangles.vertex[triangles.vertex_index]
        normals = triangles.normal[triangles.normal_index][:, 0]
        outward = np.einsum("ij,ij->i", np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), normals)
        assert np.all(outward >= 0)  # the normals face the way the triangles wind
    # the gripper's boxes are URDF primitives
    assert urdf_text.count("<box ") >= 8


def test_rpy_is_urdfs_fixed_axis_convention() -> None:
    roll, pitch, yaw = 0.3, -0.7, 2.1
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (rz @ ry @ rx).ravel())
    assert quat_to_rpy(quat) == pytest.approx((roll, pitch, yaw))
