"""The head RGB-D camera in simulation: MuJoCo renders colour and depth offscreen on the CPU.

Why it is cheap enough: it draws only simple shapes (the world's boxes and cylinders, the robot's convex collision
geometry, never its 930k-triangle meshes), without shadows, reflections or multisampling. Measured here at
640 x 480: about 3.5 ms per colour image and as much per depth image.

EGL contexts belong to the thread that made them: create and use a camera on one thread.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import mujoco
import numpy as np

from robot.model import humanoid_v1
from robot.perception.geometry import MUJOCO_TO_OPTICAL, PinholeIntrinsics, transform

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
        self._camera_id = model.camera(camera).id
        try:
            self._renderer = mujoco.Renderer(model, height, width)
        except Exception as exc:
            raise RuntimeError(
                f"offscreen rendering is not available (MUJOCO_GL={os.environ.get('MUJOCO_GL')!r}): {exc}. "
                "It needs Debian's libegl1 (MUJOCO_GL=egl) or libosmesa6 (MUJOCO_GL=osmesa), set before mujoco "
                "is first imported (importing `robot` first does that)."
            ) from exc
        self.depth_noise_per_m2 = depth_noise_per_m2
        self._rng = np.random.default_rng(seed)
        self._option = mujoco.MjvOption()
        self._option.geomgroup[:] = CAMERA_GEOM_GROUPS
        self.intrinsics = PinholeIntrinsics.from_vertical_fov(width, height, float(model.cam_fovy[self._camera_id]))

    def pose(self, data: mujoco.MjData) -> np.ndarray:
        """World from optical frame, from the simulation's (true) kinematics."""
        rotation = data.cam_xmat[self._camera_id].reshape(3, 3) @ MUJOCO_TO_OPTICAL
        return transform(rotation, data.cam_xpos[self._camera_id].copy())

    def capture(self, data: mujoco.MjData) -> RGBDImage:
        """Colour and depth of the scene as `data` poses it (its kinematics must be current)."""
        renderer = self._renderer
        renderer.disable_depth_rendering()
        self._update_scene(data)
        rgb = renderer.render().copy()
        renderer.enable_depth_rendering()
        self._update_scene(data)
        depth = renderer.render().astype(np.float32, copy=True)
        if self.depth_noise_per_m2 > 0:
            depth += (self._rng.standard_normal(depth.shape) * self.depth_noise_per_m2 * depth**2).astype(np.float32)
        depth[(depth > MAX_DEPTH_M) | (depth < MIN_DEPTH_M)] = 0.0
        return RGBDImage(rgb, depth, self.intrinsics, self.pose(data))

    def _update_scene(self, data: mujoco.MjData) -> None:
        renderer = self._renderer
        renderer.update_scene(data, camera=self._camera_id, scene_option=self._option)
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0

    def close(self) -> None:
        self._renderer.close()
