"""Colour and depth of one MuJoCo camera from a single offscreen render.

MuJoCo's `Renderer` draws the scene once per image kind, so an RGB-D frame cost two renders; the framebuffer
already holds both after one, and `mjr_readPixels` reads them together (measured here at 640 x 480, software GL:
~5 ms per render, ~0.6 ms to read both). Sensing is the largest CPU consumer of the simulated robot, and on two
cores every millisecond it spends is one the operator's browser waits for (the e-stop press included).

An EGL/OSMesa context belongs to the thread that made it: create, use and close one of these on one thread.
"""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco import gl_context

MAX_GEOMS = 10000


class OffscreenRgbd:
    """Renders `camera_id` of `model` into an RGB image and a metric z-depth image (0 where nothing is hit)."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, option: mujoco.MjvOption) -> None:
        if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
            raise ValueError(f"{width} x {height} is larger than the model's offscreen framebuffer")
        self._model = model
        self._option = option
        self._closed = True  # until both contexts exist
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._scene = mujoco.MjvScene(model=model, maxgeom=MAX_GEOMS)
        self._camera = mujoco.MjvCamera()
        self._perturb = mujoco.MjvPerturb()
        self._gl = gl_context.GLContext(width, height) if gl_context.GLContext is not None else None
        if self._gl is not None:
            self._gl.make_current()
        self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._closed = False
        self._rgb = np.empty((height, width, 3), dtype=np.uint8)
        self._depth = np.empty((height, width), dtype=np.float32)
        # OpenGL's depth buffer holds reversed-Z window depth; metric z = d / (buffer + c) (see glFrustum)
        extent = model.stat.extent
        near = np.float32(model.vis.map.znear * extent)
        far = np.float32(model.vis.map.zfar * extent)
        self._c = np.float32(-0.5) * (-(far + near) / (far - near)) - np.float32(0.5)
        self._d = np.float32(-0.5) * (-(np.float32(2) * far * near) / (far - near))

    def render(self, data: mujoco.MjData, camera_id: int) -> tuple[np.ndarray, np.ndarray]:
        """(rgb uint8 HxWx3, depth float32 HxW in m), rows top to bottom; `data`'s kinematics must be current."""
        if self._gl is not None:
            self._gl.make_current()  # another camera on this thread may have made its own context current
        camera = self._camera
        camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        camera.fixedcamid = camera_id
        scene = self._scene
        mujoco.mjv_updateScene(
            self._model, data, self._option, self._perturb, camera, mujoco.mjtCatBit.mjCAT_ALL.value, scene
        )
        scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0
        mujoco.mjr_render(self._rect, scene, self._context)
        mujoco.mjr_readPixels(self._rgb, self._depth, self._rect, self._context)
        rgb = np.flipud(self._rgb).copy()  # OpenGL's rows run bottom to top
        depth = np.flipud(self._depth).astype(np.float64)
        depth = (self._d / (depth + self._c)).astype(np.float32)
        return rgb, depth

    def close(self) -> None:
        """Frees the GL resources (with this context current, as MuJoCo needs), once."""
        if self._closed:
            return
        self._closed = True
        if self._gl is None:
            self._context.free()
            return
        with self._gl.as_current():
            self._context.free()
        self._gl.free()

    def __del__(self) -> None:
        # freed before its attributes are released: the GL context outliving the MuJoCo context that uses it
        if getattr(self, "_closed", True) is False:
            self.close()
