"""The 3D mirrors in their own process draw the robot from the robot process's own messages, at a lower CPU
priority than the web server, go on drawing after the robot process is restarted, and send a shift-clicked goal
back to the robot."""

from __future__ import annotations

import asyncio
import time

import msgspec
import psutil
import viser
import websockets
from viser._messages import ScenePointerMessage, ViewerCameraMessage

from app.bench.server import free_port
from app.mirror_process import MIRROR_NICE, MirrorProcess
from robot.interface import Mode, StopTeleop, Teleop
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


async def shift_click(port: int, origin: tuple[float, float, float], direction: tuple[float, float, float]) -> None:
    """What a viewer's browser sends for a shift+click in the 3D view (viser's own message), then stays a moment
    (a click from a viewer that has gone is dropped)."""
    camera = ViewerCameraMessage((1.0, 0.0, 0.0, 0.0), origin, 1.0, 0.01, 100.0, 480, 640, (0.0, 0.0, 0.0),
                                 (0.0, 0.0, 1.0))  # fmt: skip
    click = ScenePointerMessage("click", origin, direction, ((0.5, 0.5),), "shift")
    async with websockets.connect(f"ws://127.0.0.1:{port}", max_size=None,
                                  subprotocols=[f"viser-v{viser.__version__}"]) as viewer:  # fmt: skip
        # viser counts a viewer as connected (and takes its clicks) from its first camera message
        for message in (camera, click):
            await viewer.send(msgspec.msgpack.encode(message.as_serializable_dict()))
        deadline = time.monotonic() + 1.0
        while (left := deadline - time.monotonic()) > 0:
            try:
                await asyncio.wait_for(viewer.recv(), timeout=left)
            except TimeoutError:
                break


def drive(worker: WorkerProcess, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        assert worker.submit(Teleop(0.1, 0.0, 0.4)).accepted
        time.sleep(0.1)
    worker.submit(StopTeleop())


def test_the_mirrors_draw_the_robot_process_state_go_on_after_it_is_restarted_and_send_clicked_goals() -> None:
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
        # a shift+click on the floor at (0.6, -0.4), from the mirrors' process back to the robot process: refused
        # while the robot still stops its teleop walk, and the refusal is said
        clicked = lambda: asyncio.run(shift_click(mirrors.mirrors["full"].port, (-2.4, -2.4, 3.0), (0.6, 0.4, -0.6)))  # noqa: E731
        clicked()
        wait_until(lambda: any(e.kind == "mirror/click_refused" for e in worker.recent_events()), timeout=10)
        assert worker.state().plan is None
        wait_until(lambda: worker.state().mode == Mode.IDLE, timeout=10)
        clicked()
        wait_until(lambda: worker.state().plan is not None, timeout=10)
        plan = worker.state().plan
        assert "clicked in the 3D view" in plan.command_text
        assert [(s.action, s.args) for s in plan.steps] == [("navigate_to", {"target": "0.60, -0.40"})]
        worker.restart()  # as the supervisor would: the mirror keeps its feed
        after_restart = mirrors.mirrors["light"].updates
        drive(worker, 2.0)
        wait_until(lambda: mirrors.mirrors["light"].updates > after_restart + 10, timeout=10)
    finally:
        mirrors.stop()
        worker.stop()
