"""The 3D mirror follows the robot, and stays quiet when nothing visibly moved (viewers render on demand)."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.bench.server import free_port
from app.mirror import VISIBLE_CHANGE, SceneMirror


class MovablePort:
    """Wraps a worker so the test can move the robot's reported pose."""

    def __init__(self, worker) -> None:
        self.worker = worker
        self.offset = np.zeros(len(worker.state().qpos))

    def state(self):
        state = self.worker.state()
        return dataclasses.replace(state, qpos=tuple(np.asarray(state.qpos) + self.offset))

    def describe(self):
        return self.worker.describe()


def test_mirror_pushes_visible_motion_only(make_worker) -> None:
    port = MovablePort(make_worker(realtime=False))
    mirror = SceneMirror(port, "127.0.0.1", free_port())
    try:
        assert mirror.update_once()  # first picture
        port.offset[0] += VISIBLE_CHANGE / 10
        assert not mirror.update_once()  # sub-millimetre jitter is not sent
        port.offset[0] += 0.05
        assert mirror.update_once()
        trunk = mirror.model.body("body_link").id
        assert mirror.data.xpos[trunk][0] == np.asarray(port.state().qpos)[0]
        assert mirror.updates == 2
    finally:
        mirror.stop()
