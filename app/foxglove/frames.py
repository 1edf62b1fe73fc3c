"""Every body of the scene as a frame (FrameTransforms from each body's parent, rooted at "world"), and the world's
own shapes (furniture, walls, objects) as a SceneUpdate attached to those frames.

The robot's bodies are its URDF's links (robot.model.urdf names them after the bodies), so these transforms move
the robot the 3D panels draw from /robot_description; the robot's shapes are left to that description.
"""

from __future__ import annotations

import mujoco
import numpy as np
from foxglove.messages import (
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    Point3,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    TriangleListPrimitive,
)

from app.foxglove.messages import WORLD_FRAME, pose, quaternion, stamp, vector
from robot.model import humanoid_v1
from robot.model.urdf import subtree


def _quat_conjugate(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton products of (n, 4) wxyz quaternions."""
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=1,
    )


class SceneFrames:
    """Body poses from a simulation state (qpos, mocap positions), as transforms from each body's parent."""

    def __init__(self, model: mujoco.MjModel, robot_root: str = humanoid_v1.TRUNK_BODY) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.names = [WORLD_FRAME] + [model.body(i).name or f"body_{i}" for i in range(1, model.nbody)]
        self.parents = np.asarray(model.body_parentid[1:], dtype=int)
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot_root)
        self.robot_bodies = set(subtree(model, root)) if root >= 0 else set()

    def relative_poses(self, qpos: np.ndarray, mocap: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Each body's (1..nbody-1) translation and rotation (wxyz) in its parent's frame."""
        m, d = self.model, self.data
        n = min(qpos.size, m.nq)
        d.qpos[:n] = np.nan_to_num(qpos[:n])
        if mocap is not None and mocap.size == d.mocap_pos.size and np.all(np.isfinite(mocap)):
            d.mocap_pos[:] = mocap.reshape(d.mocap_pos.shape)
        mujoco.mj_kinematics(m, d)
        parents = self.parents
        rot_p = d.xmat[parents].reshape(-1, 3, 3)
        translation = np.einsum("bji,bj->bi", rot_p, d.xpos[1:] - d.xpos[parents])
        return translation, _quat_multiply(_quat_conjugate(d.xquat[parents]), d.xquat[1:])

    def transforms(self, qpos: np.ndarray, mocap: np.ndarray | None, t_ns: int) -> FrameTransforms:
        translation, rotation = self.relative_poses(qpos, mocap)
        names, when = self.names, stamp(t_ns)
        return FrameTransforms(
            transforms=[
                FrameTransform(
                    timestamp=when,
                    parent_frame_id=names[p],
                    child_frame_id=names[b + 1],
                    translation=vector(t),
                    rotation=quaternion(q),
                )
                for b, (p, t, q) in enumerate(zip(self.parents, translation, rotation, strict=True))
            ]
        )

    def world_scene(self, t_ns: int) -> SceneUpdate:
        """Every drawable geom of the world (not the robot's) as a primitive in its body's frame (frame-locked: it
        moves with the body)."""
        m = self.model
        by_body: dict[int, dict[str, list]] = {}
        for g in range(m.ngeom):
            body = int(m.geom_bodyid[g])
            if body in self.robot_bodies or m.geom_rgba[g][3] == 0:
                continue
            prims = by_body.setdefault(body, {"cubes": [], "spheres": [], "cylinders": [], "triangles": []})
            self._add_geom(g, prims)
        when = stamp(t_ns)
        return SceneUpdate(
            entities=[
                SceneEntity(timestamp=when, frame_id=self.names[b], id=self.names[b], frame_locked=True, **prims)
                for b, prims in by_body.items()
            ]
        )

    def _add_geom(self, g: int, prims: dict[str, list]) -> None:
        m = self.model
        rgba = m.mat_rgba[m.geom_matid[g]] if m.geom_matid[g] >= 0 else m.geom_rgba[g]
        color = Color(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3]))
        where = pose(m.geom_pos[g], m.geom_quat[g])
        size = m.geom_size[g]
        kind = m.geom_type[g]
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            prims["cubes"].append(CubePrimitive(pose=where, size=vector(2 * size), color=color))
        elif kind == mujoco.mjtGeom.mjGEOM_PLANE:
            extent = [2 * s if s > 0 else 20.0 for s in size[:2]]
            prims["cubes"].append(CubePrimitive(pose=where, size=vector([extent[0], extent[1], 0.002]), color=color))
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            prims["spheres"].append(SpherePrimitive(pose=where, size=vector([2 * size[0]] * 3), color=color))
        elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            prims["spheres"].append(SpherePrimitive(pose=where, size=vector(2 * size), color=color))
        elif kind in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE):
            r, h = size[0], size[1]
            prims["cylinders"].append(
                CylinderPrimitive(
                    pose=where, size=vector([2 * r, 2 * r, 2 * h]), bottom_scale=1.0, top_scale=1.0, color=color
                )
            )
            if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
                rot = np.zeros(9)
                mujoco.mju_quat2Mat(rot, m.geom_quat[g])
                axis = rot.reshape(3, 3)[:, 2]
                for sign in (-1.0, 1.0):
                    centre = m.geom_pos[g] + sign * h * axis
                    sphere = SpherePrimitive(pose=pose(centre, m.geom_quat[g]), size=vector([2 * r] * 3), color=color)
                    prims["spheres"].append(sphere)
        elif kind == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = m.geom_dataid[g]
            verts = m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
            faces = m.mesh_face[m.mesh_faceadr[mesh] : m.mesh_faceadr[mesh] + m.mesh_facenum[mesh]]
            points = [Point3(x=float(v[0]), y=float(v[1]), z=float(v[2])) for v in verts]
            prims["triangles"].append(
                TriangleListPrimitive(pose=where, points=points, color=color, indices=[int(i) for i in faces.ravel()])
            )
