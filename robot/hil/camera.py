"""The rig's head camera: RGB-D frames rendered from where the simulated robot's head is, streamed to whoever
connects to its Unix socket (the robot's `realsense_rig.RigFrameSource`, which feeds them to librealsense)."""

from __future__ import annotations

import contextlib
import os
import socket
import threading
import time
from typing import Protocol

import mujoco

from robot.perception.camera import SimRGBDCamera
from robot.sensors.rgbd_stream import RgbdFrame, encode_frame

CAMERA_HZ = 10.0


class ScenePose(Protocol):
    def pose_into(self, data: mujoco.MjData) -> float:
        """The scene's pose now into `data`; returns its physics time."""
        ...


class RigCamera:
    def __init__(
        self, model: mujoco.MjModel, scene: ScenePose, path: str, seed: int = 0, hz: float = CAMERA_HZ
    ) -> None:
        """`scene`: where the scene's pose comes from (the physics' `SceneShare`)."""
        self.model = model
        self.scene = scene
        self.path = path
        self.hz = hz
        self.frames_sent = 0
        self._seed = seed
        self._server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._server.bind(path)
        self._server.listen(1)
        self._server.settimeout(0.2)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="rig-camera", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self._server.close()
        with contextlib.suppress(OSError):
            os.unlink(self.path)

    def _run(self) -> None:
        data = mujoco.MjData(self.model)
        camera = SimRGBDCamera(self.model, seed=self._seed)  # its GL context belongs to this thread
        try:
            while not self._stop.is_set():
                try:
                    client, _ = self._server.accept()
                except TimeoutError:
                    continue
                except OSError:
                    return
                with client:
                    self._stream(client, data, camera)
        finally:
            camera.close()

    def _stream(self, client: socket.socket, data: mujoco.MjData, camera: SimRGBDCamera) -> None:
        period = 1.0 / self.hz
        next_frame = time.monotonic()
        while not self._stop.is_set():
            stamp = self.scene.pose_into(data)
            mujoco.mj_kinematics(self.model, data)
            mujoco.mj_camlight(self.model, data)
            image = camera.capture(data)
            frame = RgbdFrame(self.frames_sent, stamp, image.rgb, image.depth, image.intrinsics)
            try:
                client.sendall(encode_frame(frame))
            except OSError:
                return  # the robot went away: wait for the next one
            self.frames_sent += 1
            next_frame += period
            self._stop.wait(max(0.0, next_frame - time.monotonic()))
