"""Where the head (and so the camera) points: a pan/tilt target reached at a limited speed, and look-at geometry.

The head's joints are the camera's gimbal. Whoever owns the other joints (walking, postures), the head's targets
come from here; perception asks it to look at a point, or to sweep.
"""

from __future__ import annotations

import functools
import math

import mujoco
import numpy as np

from robot.control.clamp import clamp
from robot.model import humanoid_v1

# Looking 17 deg down: the floor from 1 m ahead, and table tops across the room.
DEFAULT_TILT = -0.3
MAX_SPEED_RAD_S = 2.0
SETTLED_RAD = 0.01


class HeadController:
    def __init__(self, start: tuple[float, float] = (0.0, 0.0), tilt: float = DEFAULT_TILT) -> None:
        """`start`: where the head is (the joint targets it has now); it then turns to look ahead and down."""
        limits = humanoid_v1.joint_limits()
        self.pan_limits = (limits["head_pan"].lower + 0.05, limits["head_pan"].upper - 0.05)
        self.tilt_limits = (limits["head_tilt"].lower + 0.05, limits["head_tilt"].upper - 0.05)
        self.command = self._clip(*start)
        self.target = self._clip(0.0, tilt)
        self._pan_axis, self._tilt_axis = _head_axes()

    def _clip(self, pan: float, tilt: float) -> tuple[float, float]:
        if not (math.isfinite(pan) and math.isfinite(tilt)):
            raise ValueError("head angles must be finite")
        return (clamp(pan, *self.pan_limits), clamp(tilt, *self.tilt_limits))

    def point(self, pan: float, tilt: float) -> tuple[float, float]:
        """Aim at these joint angles (clipped to the joint limits); returns the target actually set."""
        self.target = self._clip(pan, tilt)
        return self.target

    def reset(self, start: tuple[float, float] = (0.0, 0.0)) -> None:
        """The head was put at `start` (a reset): from there, look ahead and down again."""
        self.command = self._clip(*start)
        self.point(0.0, DEFAULT_TILT)

    def freeze(self) -> None:
        """Stay where it is now (an e-stop holds every joint; nothing resumes on release)."""
        self.target = self.command

    def angles_to_look_at(
        self, trunk_position: np.ndarray, trunk_rotation: np.ndarray, target: np.ndarray
    ) -> tuple[float, float, bool]:
        """Pan and tilt that centre `target` (world) in the camera, for a trunk at this pose; and whether it is
        within the head's reach (False: turn the body, or look from where the head is)."""
        local = trunk_rotation.T @ (np.asarray(target, dtype=float) - trunk_position)
        rel = local - self._pan_axis
        pan = math.atan2(rel[1], rel[0])
        c, s = math.cos(-pan), math.sin(-pan)
        turned = np.array([c * rel[0] - s * rel[1], s * rel[0] + c * rel[1], rel[2]])
        tilt_rel = turned - (self._tilt_axis - self._pan_axis)
        tilt = math.atan2(tilt_rel[2], math.hypot(tilt_rel[0], tilt_rel[1]))
        pan_ok = self.pan_limits[0] <= pan <= self.pan_limits[1]
        reachable = pan_ok and self.tilt_limits[0] <= tilt <= self.tilt_limits[1]
        return pan, tilt, reachable

    def update(self, dt: float) -> tuple[float, float]:
        """The head's joint targets for this tick, moving towards the target at the speed limit."""
        step = MAX_SPEED_RAD_S * dt
        pan = self.command[0] + clamp(self.target[0] - self.command[0], -step, step)
        tilt = self.command[1] + clamp(self.target[1] - self.command[1], -step, step)
        self.command = (pan, tilt)
        return self.command

    @property
    def at_target(self) -> bool:
        pan_error = abs(self.command[0] - self.target[0])
        return pan_error < SETTLED_RAD and abs(self.command[1] - self.target[1]) < SETTLED_RAD


@functools.cache
def _head_axes() -> tuple[np.ndarray, np.ndarray]:
    """Positions of the pan and tilt axes in the trunk frame, from the model at zero pose."""
    model = humanoid_v1.remove_drawn_meshes(humanoid_v1.build_robot_spec()).compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    trunk = model.body(humanoid_v1.TRUNK_BODY).id
    rotation = data.xmat[trunk].reshape(3, 3)
    origin = data.xpos[trunk]

    def local(body: str) -> np.ndarray:
        return rotation.T @ (data.xpos[model.body(body).id] - origin)

    return local("head_pan_link"), local(humanoid_v1.HEAD_CAMERA_BODY)
