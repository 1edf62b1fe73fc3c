"""The robot as a URDF (links, joints, limits, inertials, shapes), generated from the MuJoCo model the simulator
runs, for the tools that read robot descriptions: Foxglove's and Lichtblick's 3D panels, RViz, URDF libraries.

The file carries everything it needs: the convex shapes the simulator collides with are embedded as COLLADA
`data:` URIs (robot.model.collada), and boxes, spheres and cylinders are URDF primitives, so it draws the robot on
any machine. The detailed display meshes (~355k triangles) are left out.

Frames: each link is the MuJoCo body of the same name (the body's frame, not its centre of mass), so transforms
published per body name (an exported session's /tf) move the URDF's links. Cameras become fixed links named after
them, in the ROS optical convention (z forward, x right, y down), so images can name them as their frame.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from robot.model import humanoid_v1
from robot.model.collada import collada_document, data_uri

# MuJoCo camera (x right, y up, looking along -z) -> ROS optical frame (x right, y down, looking along +z)
_CAMERA_TO_OPTICAL = np.array([0.0, 1.0, 0.0, 0.0])  # wxyz: half a turn about x


def _fmt(values: Iterable[float]) -> str:
    """Numbers separated by single spaces (some URDF readers split on exactly one space)."""
    return " ".join(f"{float(v) + 0.0:.9g}" for v in values)  # (+ 0.0: no "-0")


def quat_to_rpy(wxyz: np.ndarray) -> tuple[float, float, float]:
    """URDF's roll, pitch, yaw (fixed axes x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll)) of a wxyz quaternion."""
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, np.asarray(wxyz, dtype=float))
    r = m.reshape(3, 3)
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(r[2, 0]) < 1.0 - 1e-9:
        roll = math.atan2(r[2, 1], r[2, 2])
        yaw = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: yaw absorbs roll
        roll = 0.0
        yaw = math.atan2(-r[0, 1], r[1, 1])
    return roll, pitch, yaw


def _origin(parent: ET.Element, pos: np.ndarray, wxyz: np.ndarray) -> None:
    ET.SubElement(parent, "origin", xyz=_fmt(pos), rpy=_fmt(quat_to_rpy(wxyz)))


def subtree(model: mujoco.MjModel, root: int) -> list[int]:
    """Body ids of `root` and all its descendants, parents before children (MuJoCo numbers bodies that way)."""
    inside = {root}
    for b in range(root + 1, model.nbody):
        if int(model.body_parentid[b]) in inside:
            inside.add(b)
    return sorted(inside)


@dataclass(frozen=True)
class JointLimits:
    lower: float
    upper: float
    effort: float  # N m or N: the most its actuator can push
    velocity: float  # rad/s or m/s: where the joint's damping takes the whole actuator force


def joint_limits(model: mujoco.MjModel, joint: int) -> JointLimits:
    """From the model: the range, the actuator's force limit, and the speed at which the joint's damping absorbs
    that force (its top speed in simulation)."""
    lower, upper = (float(v) for v in model.jnt_range[joint]) if model.jnt_limited[joint] else (0.0, 0.0)
    effort = 0.0
    for a in range(model.nu):
        drives = model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and model.actuator_trnid[a, 0] == joint
        if drives and model.actuator_forcelimited[a]:
            effort = max(effort, float(np.max(np.abs(model.actuator_forcerange[a]))))
    damping = float(model.dof_damping[model.jnt_dofadr[joint]])
    return JointLimits(lower, upper, effort, effort / damping if damping > 0 else 0.0)


Mimics = dict[int, tuple[int, float, float]]  # joint -> (the joint it follows, multiplier, offset)


def mimicked_joints(model: mujoco.MjModel) -> Mimics:
    """Joints tied to another by a joint equality (q1 = offset + multiplier * q2): {q1: (q2, multiplier, offset)}."""
    out = {}
    for e in range(model.neq):
        if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and model.eq_obj2id[e] >= 0:
            coef = model.eq_data[e]
            out[int(model.eq_obj1id[e])] = (int(model.eq_obj2id[e]), float(coef[1]), float(coef[0]))
    return out


def _add_joint(robot: ET.Element, model: mujoco.MjModel, body: int, mimics: Mimics) -> None:
    child = model.body(body).name
    parent = model.body(int(model.body_parentid[body])).name
    joints = range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body])
    if len(joints) > 1:
        raise ValueError(f"body {child!r} has {len(joints)} joints: URDF allows one per link")
    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): "revolute", int(mujoco.mjtJoint.mjJNT_SLIDE): "prismatic"}
    j = joints[0] if joints else None
    if j is not None and int(model.jnt_type[j]) not in kinds:
        raise ValueError(f"joint {model.joint(j).name!r} is neither a hinge nor a slide")
    if j is not None and np.any(model.jnt_pos[j] != 0):
        raise ValueError(f"joint {model.joint(j).name!r} is not at its body's origin")
    element = ET.SubElement(
        robot,
        "joint",
        name=model.joint(j).name if j is not None else f"{child}_fixed",
        type=kinds[int(model.jnt_type[j])] if j is not None else "fixed",
    )
    _origin(element, model.body_pos[body], model.body_quat[body])
    ET.SubElement(element, "parent", link=parent)
    ET.SubElement(element, "child", link=child)
    if j is None:
        return
    ET.SubElement(element, "axis", xyz=_fmt(model.jnt_axis[j]))
    source = mimics[j][0] if j in mimics else j
    limits = joint_limits(model, source)
    if j in mimics:  # its own range, with the drive of the joint it follows
        own = joint_limits(model, j)
        limits = JointLimits(own.lower, own.upper, limits.effort, limits.velocity)
    ET.SubElement(
        element,
        "limit",
        lower=_fmt([limits.lower]),
        upper=_fmt([limits.upper]),
        effort=_fmt([limits.effort]),
        velocity=_fmt([limits.velocity]),
    )
    ET.SubElement(
        element,
        "dynamics",
        damping=_fmt([model.dof_damping[model.jnt_dofadr[j]]]),
        friction=_fmt([model.dof_frictionloss[model.jnt_dofadr[j]]]),
    )
    if j in mimics:
        followed, multiplier, offset = mimics[j]
        ET.SubElement(
            element, "mimic", joint=model.joint(followed).name, multiplier=_fmt([multiplier]), offset=_fmt([offset])
        )


def _geometry(parent: ET.Element, model: mujoco.MjModel, g: int, meshes: dict[int, str]) -> list[ET.Element]:
    """The geom as URDF geometry (a capsule as a cylinder and two spheres); each is (origin, geometry)."""
    kind, size = model.geom_type[g], model.geom_size[g]
    pos, quat = model.geom_pos[g], model.geom_quat[g]
    shapes: list[tuple[np.ndarray, str, dict[str, str]]] = []
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        shapes.append((pos, "box", {"size": _fmt(2 * size)}))
    elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        shapes.append((pos, "sphere", {"radius": _fmt(size[:1])}))
    elif kind in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE):
        shapes.append((pos, "cylinder", {"radius": _fmt(size[:1]), "length": _fmt([2 * size[1]])}))
        if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, quat)
            axis = rot.reshape(3, 3)[:, 2]
            shapes += [(pos + s * size[1] * axis, "sphere", {"radius": _fmt(size[:1])}) for s in (-1.0, 1.0)]
    elif kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[g])
        if mesh not in meshes:
            meshes[mesh] = data_uri(_mesh_document(model, mesh))
        shapes.append((pos, "mesh", {"filename": meshes[mesh]}))
    else:
        body = model.body(int(model.geom_bodyid[g])).name
        raise ValueError(f"geom {g} of body {body!r}: type {kind} has no URDF shape")
    elements = []
    for centre, tag, attributes in shapes:
        element = ET.Element(parent.tag)
        _origin(element, centre, quat)
        ET.SubElement(ET.SubElement(element, "geometry"), tag, **attributes)
        elements.append(element)
    return elements


def _mesh_document(model: mujoco.MjModel, mesh: int) -> bytes:
    v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
    name = model.mesh(mesh).name or f"mesh{mesh}"
    return collada_document(model.mesh_vert[v0 : v0 + nv], model.mesh_face[f0 : f0 + nf], name=name)


def _colour(model: mujoco.MjModel, g: int) -> np.ndarray:
    return model.mat_rgba[model.geom_matid[g]] if model.geom_matid[g] >= 0 else model.geom_rgba[g]


def _add_link(
    robot: ET.Element, model: mujoco.MjModel, body: int, skip_groups: set[int], meshes: dict[int, str]
) -> None:
    link = ET.SubElement(robot, "link", name=model.body(body).name)
    inertial = ET.SubElement(link, "inertial")
    _origin(inertial, model.body_ipos[body], model.body_iquat[body])
    ET.SubElement(inertial, "mass", value=_fmt([model.body_mass[body]]))
    ixx, iyy, izz = model.body_inertia[body]  # principal axes: the inertial origin's rotation
    ET.SubElement(inertial, "inertia", ixx=_fmt([ixx]), ixy="0", ixz="0", iyy=_fmt([iyy]), iyz="0", izz=_fmt([izz]))
    geoms = range(model.body_geomadr[body], model.body_geomadr[body] + model.body_geomnum[body])
    for g in geoms:
        if int(model.geom_group[g]) in skip_groups or _colour(model, g)[3] == 0:
            continue
        for visual in _geometry(ET.Element("visual"), model, g, meshes):
            material = ET.SubElement(visual, "material", name=f"{model.body(body).name}_{g}")
            ET.SubElement(material, "color", rgba=_fmt(_colour(model, g)))
            link.append(visual)
    for g in geoms:
        if int(model.geom_group[g]) in skip_groups or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        link.extend(_geometry(ET.Element("collision"), model, g, meshes))


def _add_cameras(robot: ET.Element, model: mujoco.MjModel, bodies: set[int]) -> None:
    names = {model.body(b).name for b in bodies}
    for c in range(model.ncam):
        name, body = model.cam(c).name, int(model.cam_bodyid[c])
        if not name or body not in bodies or name in names:
            continue
        optical = np.zeros(4)
        mujoco.mju_mulQuat(optical, model.cam_quat[c], _CAMERA_TO_OPTICAL)
        ET.SubElement(robot, "link", name=name)
        joint = ET.SubElement(robot, "joint", name=f"{name}_fixed", type="fixed")
        _origin(joint, model.cam_pos[c], optical)
        ET.SubElement(joint, "parent", link=model.body(body).name)
        ET.SubElement(joint, "child", link=name)


def urdf_from_model(
    model: mujoco.MjModel,
    root_body: str,
    robot_name: str,
    skip_groups: Iterable[int] = (humanoid_v1.DETAILED_MESH_GROUP,),
) -> str:
    """The subtree of `root_body` (the robot's floating base, without its free joint) as a URDF document.
    Geoms in `skip_groups` are left out; ValueError for what URDF cannot say (a ball joint, two joints on one
    body, a plane)."""
    root = model.body(root_body).id
    bodies = subtree(model, root)
    robot = ET.Element("robot", name=robot_name)
    meshes: dict[int, str] = {}
    mimics = mimicked_joints(model)
    for body in bodies:
        _add_link(robot, model, body, set(skip_groups), meshes)
        if body != root:
            _add_joint(robot, model, body, mimics)
    _add_cameras(robot, model, set(bodies))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


@functools.cache
def robot_urdf() -> str:
    """humanoid_v1 (robot.model.humanoid_v1.build_robot_spec) as a URDF. The detailed meshes, which the URDF
    leaves out, are taken out of the spec before it compiles (4 s less; every OP3 body states its inertia)."""
    spec = humanoid_v1.remove_drawn_meshes(humanoid_v1.build_robot_spec())
    return urdf_from_model(spec.compile(), humanoid_v1.TRUNK_BODY, humanoid_v1.MODEL_NAME)
