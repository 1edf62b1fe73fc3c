"""The live 3D mirror: a viser server that shows the robot and its world as the worker reports them. viser has no
login, so it listens on loopback only, on a port of the system's choosing; browsers reach it through its gate
(`app.viz.scene_gate`, on the port the settings name), which checks their login.

The mirror only reads `RobotState` snapshots (qpos) and the model from `RobotDescription`; it recomputes body
poses in its own MjData, so it never touches the worker's simulation. mjviser builds the scene from the model.
"""

from __future__ import annotations

import logging
import ssl
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
import viser
from mjviser.scene import ViserMujocoScene

from app.auth.scene_tokens import SceneGrant
from app.viz.click_goal import HINT as CLICK_HINT
from app.viz.click_goal import enable_clicks
from app.viz.perception_overlay import NavigationOverlay, PerceptionOverlay
from app.viz.scene_gate import ClickHandler, SceneGate
from robot.interface import LocomotionState, RobotPort
from robot.model import humanoid_v1

log = logging.getLogger(__name__)

# Smallest change of a joint angle (rad) or position (m) worth showing: 0.5 mm, 0.03 deg.
VISIBLE_CHANGE = 5e-4
# Geom groups of the packaged OP3: detailed meshes to look at, convex shapes for contacts.
VISUAL_GROUP = 2
COLLISION_GROUP = 3
ROBOT_COLOUR = [0.22, 0.23, 0.26, 1.0]
FLOOR_THICKNESS = 0.01


@dataclass(frozen=True)
class MirrorProfile:
    """How much the viewers' browsers must render.

    "full" is for browsers with a GPU: the robot's detailed meshes (about 355k triangles), image-based lighting,
    an infinite floor grid. "light" is for browsers that render WebGL on the CPU: measured here, each "full" frame
    keeps Chromium's GPU process busy for ~200 ms at raised priority, which delays everything else on a small
    machine, the operator's e-stop click included. It draws the robot's convex collision shapes (about 6k
    triangles) under plain hemisphere light, on a flat floor.
    """

    name: str
    detailed_meshes: bool
    image_based_lighting: bool
    floor_grid: bool


FULL = MirrorProfile("full", detailed_meshes=True, image_based_lighting=True, floor_grid=True)
LIGHT = MirrorProfile("light", detailed_meshes=False, image_based_lighting=False, floor_grid=False)
PROFILES = {p.name: p for p in (FULL, LIGHT)}


def mirror_model(mjcf_xml: str, profile: MirrorProfile) -> mujoco.MjModel:
    """The model the viewers draw: the worker's scene, simplified as the profile asks (same bodies and qpos)."""
    if profile.detailed_meshes and profile.floor_grid:
        return mujoco.MjModel.from_xml_string(mjcf_xml)
    spec = mujoco.MjSpec.from_string(mjcf_xml)
    for geom in list(spec.geoms):
        if not profile.detailed_meshes:
            if geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.group == VISUAL_GROUP:
                spec.delete(geom)
                continue
            if geom.group == COLLISION_GROUP:
                geom.group = VISUAL_GROUP
                geom.rgba = ROBOT_COLOUR
        if not profile.floor_grid and geom.type == mujoco.mjtGeom.mjGEOM_PLANE:
            # mjviser draws planes as an infinite grid with a shadow pass; a thin box is a plain floor.
            geom.type = mujoco.mjtGeom.mjGEOM_BOX
            geom.size = [geom.size[0], geom.size[1], FLOOR_THICKNESS / 2]
            geom.pos = [geom.pos[0], geom.pos[1], geom.pos[2] - FLOOR_THICKNESS / 2]
    if not profile.detailed_meshes:  # meshes nothing draws any more: not compiled either
        drawn = {g.meshname for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_MESH}
        for mesh in [m for m in spec.meshes if m.name not in drawn]:
            spec.delete(mesh)
    return spec.compile()


# Gait overlay: how many planned footsteps can be shown, and their colours (left blue, right orange).
MAX_FOOTSTEPS = 12
FOOTSTEP_COLOURS = {"left": (60, 120, 230), "right": (240, 140, 40)}
COM_COLOUR = (230, 40, 40)
ZMP_COLOUR = (40, 180, 60)
OVERLAY_Z = 0.003  # just above the floor


class GaitOverlay:
    """Footsteps planned ahead (flat boxes the size of a sole), the CoM (a sphere) and the ZMP (a disc on the floor)."""

    def __init__(self, server: viser.ViserServer) -> None:
        scene = server.scene
        size = (humanoid_v1.FOOT_LENGTH, humanoid_v1.FOOT_WIDTH, 0.004)
        self._steps = [self._footstep(scene, i, size) for i in range(MAX_FOOTSTEPS)]
        self._com = scene.add_icosphere("/gait/com", radius=0.02, color=COM_COLOUR, cast_shadow=False, visible=False)
        self._zmp = scene.add_box(
            "/gait/zmp",
            color=ZMP_COLOUR,
            dimensions=(0.025, 0.025, 0.004),
            cast_shadow=False,
            receive_shadow=False,
            visible=False,
        )
        self.shown = False

    @staticmethod
    def _footstep(scene: viser.SceneApi, index: int, size: tuple[float, float, float]) -> viser.BoxHandle:
        return scene.add_box(
            f"/gait/footstep_{index}",
            color=FOOTSTEP_COLOURS["left"],
            dimensions=size,
            opacity=0.55,
            cast_shadow=False,
            receive_shadow=False,
            visible=False,
        )

    def update(self, loco: LocomotionState | None) -> None:
        if loco is None or loco.com is None:
            if self.shown:
                for handle in (*self._steps, self._com, self._zmp):
                    handle.visible = False
                self.shown = False
            return
        for i, handle in enumerate(self._steps):
            if i < len(loco.footsteps):
                step = loco.footsteps[i]
                handle.position = (step.x, step.y, OVERLAY_Z)
                handle.wxyz = (float(np.cos(step.yaw / 2)), 0.0, 0.0, float(np.sin(step.yaw / 2)))
                handle.color = FOOTSTEP_COLOURS.get(step.side, FOOTSTEP_COLOURS["left"])
                handle.visible = True
            elif handle.visible:
                handle.visible = False
        self._com.position = loco.com
        self._com.visible = True
        if loco.zmp is not None:
            self._zmp.position = (loco.zmp[0], loco.zmp[1], OVERLAY_Z + 0.002)
            self._zmp.visible = True
        self.shown = True


class SceneMirror:
    def __init__(
        self, port: RobotPort, rate_hz: float = 30.0, profile: MirrorProfile = FULL, shadows: bool = False
    ) -> None:
        description = port.describe()
        self._port = port
        self._period = 1.0 / rate_hz
        self.profile = profile
        self.model = mirror_model(description.mjcf_xml, profile)
        self.data = mujoco.MjData(self.model)
        self.server = viser.ViserServer(
            host="127.0.0.1", port=0, label=f"humanoid mirror ({profile.name})", verbose=False
        )
        self.server.initial_camera.position = (-3.2, -2.8, 3.0)
        self.server.initial_camera.look_at = (0.0, 0.0, 0.2)
        self.scene = ViserMujocoScene(self.server, self.model, num_envs=1)
        self.scene.camera_tracking_enabled = False  # a fixed world frame: the apartment stays put
        # Shadow maps double the cost of every frame, which matters on machines that render WebGL in software.
        self.server.scene.configure_default_lights(enabled=True, cast_shadow=shadows and profile.floor_grid)
        if not profile.image_based_lighting:
            self.server.scene.configure_environment_map(hdri=None, environment_intensity=0.0)
            self.server.scene.add_light_hemisphere(
                "/hemisphere", sky_color=(255, 255, 255), ground_color=(120, 110, 100), intensity=1.6
            )
        self.gait = GaitOverlay(self.server)
        self.perception = PerceptionOverlay(self.server)
        self.navigation = NavigationOverlay(self.server)
        enable_clicks(self.server)
        self.server.gui.add_markdown(CLICK_HINT)
        self.updates = 0
        self._last_qpos: np.ndarray | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"scene-mirror-{profile.name}", daemon=True)

    @property
    def upstream_port(self) -> int:
        """viser's own port, on loopback: only the gate connects to it."""
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
        state = self._port.state()
        feed = self._port.sensor_feed()
        perceived = self.perception.update(feed.scan, feed.map, state.perception)
        perceived |= self.navigation.update(state.navigation)
        qpos = np.asarray(state.qpos)
        scene = np.concatenate([qpos, np.asarray(state.mocap_positions, dtype=float)])  # dropped obstacles too
        if (
            self._last_qpos is not None
            and scene.shape == self._last_qpos.shape
            and np.max(np.abs(scene - self._last_qpos)) < VISIBLE_CHANGE
        ):
            if self.gait.shown and (state.locomotion is None or state.locomotion.com is None):
                self.gait.update(None)  # the walk ended while the robot stood still: clear its overlay
                perceived = True
            if perceived:
                self.server.flush()
            return perceived
        self._last_qpos = scene
        self.data.qpos[:] = qpos
        if len(state.mocap_positions) == self.data.mocap_pos.size:
            self.data.mocap_pos[:] = np.asarray(state.mocap_positions).reshape(self.data.mocap_pos.shape)
        mujoco.mj_kinematics(self.model, self.data)
        self.scene.update_from_mjdata(self.data)
        self.gait.update(state.locomotion)
        self.server.flush()
        self.updates += 1
        return True

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            if not self.server.get_clients():
                # Nobody watches: nothing to draw (and no state to decode). A viewer who comes gets the scene as last
                # drawn, then the robot where it is now within one period.
                continue
            try:
                self.update_once()
            except Exception:  # a viewer glitch must never take the mirror down for good
                log.exception("mirror update failed")
                time.sleep(1.0)


def open_views(
    port: RobotPort,
    host: str,
    ports: dict[str, int],
    rate_hz: float,
    shadows: bool,
    verify: Callable[[str], SceneGrant | None],
    on_click: ClickHandler | None,
    tls: ssl.SSLContext | None = None,
) -> tuple[dict[str, SceneMirror], dict[str, SceneGate]]:
    """The live 3D views, each a mirror behind its gate (on `host`:`ports[profile]`), started."""
    mirrors = {name: SceneMirror(port, rate_hz, profile=PROFILES[name], shadows=shadows) for name in ports}
    gates = {
        name: SceneGate(name, host, ports[name], mirror.upstream_port, verify, on_click, tls)
        for name, mirror in mirrors.items()
    }
    for name in ports:
        mirrors[name].start()
        gates[name].start()
    return mirrors, gates
