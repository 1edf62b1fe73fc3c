"""The live 3D mirror: a viser server (its own port) that shows the robot and its world as the worker reports them.

The mirror only reads `RobotState` snapshots (qpos) and the model from `RobotDescription`; it recomputes body
poses in its own MjData, so it never touches the worker's simulation. mjviser builds the scene from the model.
"""

from __future__ import annotations

import logging
import threading
import time

import mujoco
import numpy as np
import viser
from mjviser.scene import ViserMujocoScene

from robot.interface import RobotPort

log = logging.getLogger(__name__)

# Smallest change of a joint angle (rad) or position (m) worth showing: 0.5 mm, 0.03 deg.
VISIBLE_CHANGE = 5e-4
# Geom groups of the packaged OP3: detailed meshes to look at, convex shapes for contacts.
VISUAL_GROUP = 2
COLLISION_GROUP = 3


ROBOT_COLOUR = [0.22, 0.23, 0.26, 1.0]


def mirror_model(mjcf_xml: str, geometry: str) -> mujoco.MjModel:
    """The model the viewers draw. "collision" swaps the robot's detailed meshes (about 930k triangles, which a
    browser without a GPU renders at a few frames per second) for its convex collision shapes (about 6k)."""
    if geometry == "visual":
        return mujoco.MjModel.from_xml_string(mjcf_xml)
    spec = mujoco.MjSpec.from_string(mjcf_xml)
    for geom in list(spec.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.group == VISUAL_GROUP:
            spec.delete(geom)
        elif geom.group == COLLISION_GROUP:
            geom.group = VISUAL_GROUP
            geom.rgba = ROBOT_COLOUR
    return spec.compile()


class SceneMirror:
    def __init__(
        self,
        port: RobotPort,
        host: str,
        viser_port: int,
        rate_hz: float = 30.0,
        shadows: bool = False,
        geometry: str = "visual",
    ) -> None:
        description = port.describe()
        self._port = port
        self._period = 1.0 / rate_hz
        self.model = mirror_model(description.mjcf_xml, geometry)
        self.data = mujoco.MjData(self.model)
        self.server = viser.ViserServer(host=host, port=viser_port, label="humanoid mirror", verbose=False)
        self.server.initial_camera.position = (-3.2, -2.8, 3.0)
        self.server.initial_camera.look_at = (0.0, 0.0, 0.2)
        self.scene = ViserMujocoScene(self.server, self.model, num_envs=1)
        self.scene.camera_tracking_enabled = False  # a fixed world frame: the apartment stays put
        # Shadow maps double the cost of every frame, which matters on machines that render WebGL in software.
        self.server.scene.configure_default_lights(enabled=True, cast_shadow=shadows)
        self.updates = 0
        self._last_qpos: np.ndarray | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="scene-mirror", daemon=True)

    @property
    def port(self) -> int:
        return int(self.server.get_port())

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        self.server.stop()

    def update_once(self) -> bool:
        """Push the latest robot state to every viewer; returns False when nothing moved visibly.

        Viewers render on demand: an update that nobody could see (physics jitter of a standing robot) would
        still make every browser re-render the scene in software, which costs whole CPU cores.
        """
        qpos = np.asarray(self._port.state().qpos)
        if self._last_qpos is not None and np.max(np.abs(qpos - self._last_qpos)) < VISIBLE_CHANGE:
            return False
        self._last_qpos = qpos
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        self.scene.update_from_mjdata(self.data)
        self.server.flush()
        self.updates += 1
        return True

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            try:
                self.update_once()
            except Exception:  # a viewer glitch must never take the mirror down for good
                log.exception("mirror update failed")
                time.sleep(1.0)
