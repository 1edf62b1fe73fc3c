"""The head RGB-D camera in simulation: MuJoCo renders colour and depth offscreen on the CPU.

Why it is cheap enough: it draws only simple shapes (the world's boxes and cylinders, the robot's convex collision
geometry, never its detailed meshes), without shadows, reflections or multisampling. Measured here at
640 x 480: about 6 ms per RGB-D frame, colour and depth read from one render (`offscreen.py`).

EGL contexts belong to the thread that made them: create and use a camera on one thread.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import mujoco
import numpy as np

from robot.model import humanoid_v1
from robot.perception.geometry import MUJOCO_TO_OPTICAL, PinholeIntrinsics, transform
from robot.perception.offscreen import OffscreenRgbd

# Depth beyond this is reported as no return (the D435's useful range), as is the empty sky.
MAX_DEPTH_M = 6.0
MIN_DEPTH_M = 0.1
NEAR_PLANE_M = 0.02
FAR_PLANE_M = 50.0
# Depth noise grows with the square of the distance, as a stereo camera's: sigma = this x z^2 (1 mm at 1 m).
DEPTH_NOISE_PER_M2 = 0.001
# What the camera sees: the world (0), the gripper (1) and the robot's convex shapes (3); not the meshes (2).
CAMERA_GEOM_GROUPS = (1, 1, 0, 1, 0, 0)


@dataclass(frozen=True)
class RGBDImage:
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32 z-depth in m; 0 where there is no return
    intrinsics: PinholeIntrinsics
    world_from_camera: np.ndarray  # 4x4, optical frame; the true pose in simulation


class SimRGBDCamera:
    """Renders one MuJoCo camera of `model` as an RGB-D sensor."""

    def __init__(
        self,
        model: mujoco.MjModel,
        camera: str = humanoid_v1.HEAD_CAMERA,
        width: int = humanoid_v1.CAMERA_WIDTH,
        height: int = humanoid_v1.CAMERA_HEIGHT,
        depth_noise_per_m2: float = DEPTH_NOISE_PER_M2,
        seed: int = 0,
    ) -> None:
        model.vis.quality.offsamples = 0
        # MuJoCo's clipping planes scale with the model's extent (far-parked spare obstacles make it 30 m, and the
        # near plane then cut off everything within 0.3 m): set them in metres instead
        model.vis.map.znear = NEAR_PLANE_M / model.stat.extent
        model.vis.map.zfar = FAR_PLANE_M / model.stat.extent
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self._model = model
        self.camera_id = model.camera(camera).id
        self.option = mujoco.MjvOption()
        self.option.geomgroup[:] = CAMERA_GEOM_GROUPS
        try:
            self.renderer = OffscreenRgbd(model, width, height, self.option)
        except Exception as exc:
            raise RuntimeError(
                f"offscreen rendering is not available (MUJOCO_GL={os.environ.get('MUJOCO_GL')!r}): {exc}. "
                "It needs Debian's libegl1 (MUJOCO_GL=egl) or libosmesa6 (MUJOCO_GL=osmesa), set before mujoco "
                "is first imported (importing `robot` first does that)."
            ) from exc
        self.depth_noise_per_m2 = depth_noise_per_m2
        self._rng = np.random.default_rng(seed)
        # unit Gaussian noise, twice the image each way: a frame takes a window at a random offset (drawing 300k
        # normals per frame cost ~4 ms, as much as the render; a window costs ~0.2 ms and is as random per pixel)
        self._noise = self._rng.standard_normal((2 * height, 2 * width), dtype=np.float32)
        self.intrinsics = PinholeIntrinsics.from_vertical_fov(width, height, float(model.cam_fovy[self.camera_id]))

    def pose(self, data: mujoco.MjData) -> np.ndarray:
        """World from optical frame, from the simulation's (true) kinematics."""
        rotation = data.cam_xmat[self.camera_id].reshape(3, 3) @ MUJOCO_TO_OPTICAL
        return transform(rotation, data.cam_xpos[self.camera_id].copy())

    def capture(self, data: mujoco.MjData) -> RGBDImage:
        """Colour and depth of the scene as `data` poses it (its kinematics must be current)."""
        rgb, depth = self.renderer.render(data, self.camera_id)
        if self.depth_noise_per_m2 > 0:
            noise = self._noise_field(depth.shape)
            noise *= depth
            noise *= depth
            noise *= np.float32(self.depth_noise_per_m2)
            depth += noise
        depth[(depth > MAX_DEPTH_M) | (depth < MIN_DEPTH_M)] = 0.0
        return RGBDImage(rgb, depth, self.intrinsics, self.pose(data))

    def _noise_field(self, shape: tuple[int, ...]) -> np.ndarray:
        """A fresh copy of unit Gaussian noise of `shape`, a random window of the stored field."""
        height, width = shape
        top = int(self._rng.integers(0, self._noise.shape[0] - height + 1))
        left = int(self._rng.integers(0, self._noise.shape[1] - width + 1))
        return self._noise[top : top + height, left : left + width].copy()

    def close(self) -> None:
        self.renderer.close()
