"""The rig's lidar and head camera, drawn in a process of their own. In the bus's process, a rendering thread
that the scheduler preempts while it holds the interpreter kept the bus's replies waiting past the robot's
timeouts on a busy machine (servos "not answering", a failed start). The physics hands the scene's pose over in
shared memory (`SceneShare`) after each block; this process draws from it at the sensors' own rates.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from multiprocessing.connection import Connection
from multiprocessing.shared_memory import SharedMemory
from typing import Any

import mujoco
import numpy as np

from robot.model.world import WorldLayout
from robot.perception.lidar import SimLidar
from robot.sensors.ld06_emulator import TURN_S as LIDAR_TURN_S
from robot.sensors.ld06_emulator import Ld06Emulator


class SceneShare:
    """The scene's pose (time, qpos, the kinematic bodies' positions and orientations) in shared memory. Made by
    the physics' side (no `name`; it unlinks it), attached to by name by the sensors' side (a spawned process
    shares its maker's resource tracker: it is tracked once). A sequence counter guards it (odd while a write is
    under way; a reader copies again if it changed): the physics never waits for a reader."""

    def __init__(self, nq: int, nmocap: int, name: str | None = None) -> None:
        self.nq, self.nmocap = nq, nmocap
        size = (2 + nq + 7 * nmocap) * 8
        self.memory = SharedMemory(name=name, create=name is None, size=size)
        self._values = np.ndarray((2 + nq + 7 * nmocap,), dtype=np.float64, buffer=self.memory.buf)

    @property
    def name(self) -> str:
        return self.memory.name

    def write(self, data: mujoco.MjData) -> None:
        nq, nm, v = self.nq, self.nmocap, self._values
        v[0] += 1.0  # odd: writing
        v[1] = data.time
        v[2 : 2 + nq] = data.qpos
        v[2 + nq : 2 + nq + 3 * nm] = data.mocap_pos.ravel()
        v[2 + nq + 3 * nm :] = data.mocap_quat.ravel()
        v[0] += 1.0

    def pose_into(self, data: mujoco.MjData) -> float:
        """The scene's last whole pose into `data` (kinematics not run); returns its physics time."""
        nq, nm, v = self.nq, self.nmocap, self._values
        while True:
            seq = v[0]
            if seq % 2 == 1:
                time.sleep(0.0001)
                continue
            copy = v.copy()
            if v[0] == seq:
                break
        data.time = float(copy[1])
        data.qpos[:] = copy[2 : 2 + nq]
        data.mocap_pos[:] = copy[2 + nq : 2 + nq + 3 * nm].reshape(nm, 3)
        data.mocap_quat[:] = copy[2 + nq + 3 * nm :].reshape(nm, 4)
        return float(data.time)

    def close(self, unlink: bool = False) -> None:
        del self._values  # the buffer is exported while an array views it
        self.memory.close()
        if unlink:
            with contextlib.suppress(FileNotFoundError):
                self.memory.unlink()


class RigLidar:
    """An LD06 on its own pseudo-terminal (`port_name`), sending a turn every 0.1 s, each cast from the pose the
    scene had then."""

    def __init__(self, model: mujoco.MjModel, scene: SceneShare, seed: int = 0) -> None:
        self._model = model
        self._data = mujoco.MjData(model)
        self._scene = scene
        self._lidar = SimLidar(model, seed=seed)
        self._device = Ld06Emulator(self._scan())
        self.port_name = self._device.port_name
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="rig-lidar", daemon=True)

    def _scan(self) -> Any:
        self._scene.pose_into(self._data)
        mujoco.mj_kinematics(self._model, self._data)
        return self._lidar.scan(self._data)

    def start(self) -> None:
        self._device.__enter__()
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self._device.__exit__(None, None, None)

    def _run(self) -> None:
        while not self._stop.wait(LIDAR_TURN_S):
            self._device.set_scan(self._scan())


def serve_sensors(conn: Connection, layout: WorldLayout, share_name: str, camera_path: str) -> None:
    """The sensors' process: the lidar and the camera until told to stop; their ports are said first."""
    from robot.hil.camera import RigCamera
    from robot.model.scene import build_scene

    with contextlib.suppress(OSError, AttributeError):  # below the bus, as the robot's own sensors are
        os.nice(5)
    model = build_scene(layout, drawn=False)
    scene = SceneShare(model.nq, model.nmocap, name=share_name)
    lidar = RigLidar(model, scene, layout.seed)
    camera = RigCamera(model, scene, camera_path, layout.seed)
    lidar.start()
    camera.start()
    conn.send({"lidar": lidar.port_name, "camera": camera.path})
    try:
        conn.recv()  # "stop", or the rig's end of the pipe closing
    except EOFError:
        pass
    finally:
        lidar.stop()
        camera.stop()
        scene.close()
