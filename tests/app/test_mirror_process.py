"""The 3D mirrors in their own process draw the robot from the robot process's own messages, at a lower CPU
priority than the web server, and go on drawing after the robot process is restarted."""

from __future__ import annotations

import asyncio
import time

import psutil
import viser
import websockets

from app.bench.server import free_port
from app.mirror_process import MIRROR_NICE, MirrorProcess
from robot.interface import StopTeleop, Teleop
from robot.process import WorkerProcess
from tests.app.test_api import wait_until


async def scene_bytes(port: int, seconds: float) -> int:
    """What a viewer's browser is sent in its first `seconds` (the scene, then its updates)."""
    received = 0
    async with websockets.connect(f"ws://127.0.0.1:{port}", max_size=None,
                                  subprotocols=[f"viser-v{viser.__version__}"]) as viewer:  # fmt: skip
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            try:
                received += len(await asyncio.wait_for(viewer.recv(), timeout=left))
            except TimeoutError:
                break
    return received


def drive(worker: WorkerProcess, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        assert worker.submit(Teleop(0.1, 0.0, 0.4)).accepted
        time.sleep(0.1)
    worker.submit(StopTeleop())


def test_the_mirrors_draw_the_robot_process_state_and_go_on_after_it_is_restarted() -> None:
    worker = WorkerProcess(seed=0, perception=False)
    worker.start()
    mirrors = MirrorProcess(worker, "127.0.0.1", {"full": free_port(), "light": free_port()}, 30.0, shadows=False)
    mirrors.start()
    try:
        assert psutil.Process(mirrors._process.pid).nice() == MIRROR_NICE  # viewers wait, the e-stop does not
        assert asyncio.run(scene_bytes(mirrors.mirrors["light"].port, 3.0)) > 50_000  # the apartment and robot
        before = mirrors.mirrors["light"].updates
        drive(worker, 2.0)
        wait_until(lambda: mirrors.mirrors["light"].updates > before + 10, timeout=10)
        worker.restart()  # as the supervisor would: the mirror keeps its feed
        after_restart = mirrors.mirrors["light"].updates
        drive(worker, 2.0)
        wait_until(lambda: mirrors.mirrors["light"].updates > after_restart + 10, timeout=10)
    finally:
        mirrors.stop()
        worker.stop()
