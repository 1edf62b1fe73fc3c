"""Poses of the robot computed by MuJoCo, for scripts/urdf_loader_check.mjs: random joint values within the limits
and each body's pose seen from the trunk (4x4, row-major). Usage: python scripts/urdf_poses.py OUT.json [N]"""

from __future__ import annotations

import json
import sys

import mujoco
import numpy as np

from robot.model import humanoid_v1
from robot.model.urdf import mimicked_joints, subtree


def poses(count: int, seed: int = 7) -> list[dict]:
    model = humanoid_v1.build_robot_spec().compile()
    data = mujoco.MjData(model)
    trunk = model.body(humanoid_v1.TRUNK_BODY).id
    bodies = subtree(model, trunk)
    joints = [j for j in range(model.njnt) if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE]
    mimics = mimicked_joints(model)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        values = {j: float(rng.uniform(*model.jnt_range[j])) for j in joints if j not in mimics}
        values.update({j: offset + k * values[f] for j, (f, k, offset) in mimics.items()})
        for j, v in values.items():
            data.qpos[model.jnt_qposadr[j]] = v
        mujoco.mj_kinematics(model, data)

        def pose(b: int) -> np.ndarray:
            m = np.eye(4)
            m[:3, :3], m[:3, 3] = data.xmat[b].reshape(3, 3), data.xpos[b]
            return m

        inverse = np.linalg.inv(pose(trunk))
        out.append(
            {
                "base": humanoid_v1.TRUNK_BODY,
                "joints": {model.joint(j).name: v for j, v in values.items() if j not in mimics},
                "links": {model.body(b).name: (inverse @ pose(b)).ravel().tolist() for b in bodies},
            }
        )
    return out


if __name__ == "__main__":
    with open(sys.argv[1], "w") as f:
        json.dump(poses(int(sys.argv[2]) if len(sys.argv) > 2 else 5), f)
