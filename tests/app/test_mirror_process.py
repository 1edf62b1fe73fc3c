"""The 3D mirrors in their own process draw the robot from the robot process's own messages, at a lower CPU
priority than the web server, behind gates that admit only a login's token, go on drawing after the robot process
is restarted, and hand a shift-click back with who made it."""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor

import httpx
import psutil
import pytest
import websockets

from app.auth.roles import Principal, Role
from app.auth.scene_tokens import SceneGrant, SceneTokens
from app.viz.mirror_process import MIRROR_NICE, UPDATES_PERIOD_S, MirrorProcess
from harness.server import free_port
from robot.interface import EStop, ReleaseEStop, StopTeleop, Teleop
from robot.process import WorkerProcess
from tests.app.test_api import wait_until
from tests.support.scene_viewer import camera_message, connect_view, scene_bytes, shift_click, view_url


@contextlib.contextmanager
def watching(url: str) -> Iterator[list[int]]:
    """A viewer on the 3D view (as a browser: it sends its camera first) until the block ends; yields the bytes it
    has been sent so far, in a list of one."""
    received, leave = [0], threading.Event()

    async def view() -> None:
        async with connect_view(url) as viewer:
            await viewer.send(camera_message())
            while not leave.is_set():
                with contextlib.suppress(TimeoutError):
                    received[0] += len(await asyncio.wait_for(viewer.recv(), timeout=0.2))

    with ThreadPoolExecutor(max_workers=1) as pool:
        viewing = pool.submit(asyncio.run, view())
        try:
            yield received
        finally:
            leave.set()
            viewing.result(timeout=30)


def drive_until(worker: WorkerProcess, done: Callable[[], bool], timeout_s: float = 30.0) -> None:
    """Teleop the robot in a slow turn until `done()`."""
    end = time.monotonic() + timeout_s
    while not done():
        assert time.monotonic() < end, f"still not done after driving for {timeout_s:.0f} s"
        assert worker.submit(Teleop(0.1, 0.0, 0.4)).accepted
        time.sleep(0.1)
    worker.submit(StopTeleop())


def drive(worker: WorkerProcess, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        assert worker.submit(Teleop(0.1, 0.0, 0.4)).accepted
        time.sleep(0.1)
    worker.submit(StopTeleop())


def test_the_mirrors_draw_the_robot_behind_their_gates_go_on_after_a_restart_and_hand_clicks_back() -> None:
    worker = WorkerProcess(seed=0, perception=False)
    worker.start()
    tokens = SceneTokens()
    clicks: list[tuple[SceneGrant, tuple, tuple]] = []
    ports = {"full": free_port(), "light": free_port()}
    mirrors = MirrorProcess(worker, "127.0.0.1", ports, 30.0, False, tokens, lambda *click: clicks.append(click))
    mirrors.start()
    try:
        assert psutil.Process(mirrors._process.pid).nice() == MIRROR_NICE  # viewers wait, the e-stop does not
        assert {name: m.port for name, m in mirrors.mirrors.items()} == ports  # the gates listen where asked
        ada = tokens.issue(Principal("ada", Role.OPERATOR), "login-ada", time.time() + 60)
        # nothing without a token, or with a forged or expired one
        light = ports["light"]
        for path in ("/", "/index.html", "/s/forged.token/", f"/s/{ada[:-2]}xx/"):
            assert httpx.get(f"http://127.0.0.1:{light}{path}", timeout=10).status_code == 401
        expired = tokens.issue(Principal("ada", Role.OPERATOR), "login-ada", time.time() - 1)
        for url in (f"ws://127.0.0.1:{light}", view_url(light, expired)):
            with pytest.raises(websockets.InvalidStatus):
                asyncio.run(scene_bytes(url, 1.0))
        page = httpx.get(f"http://127.0.0.1:{light}/s/{ada}/?fixedDpr=0.5", timeout=10)
        assert page.status_code == 200 and '<div id="root">' in page.text
        assert page.headers["referrer-policy"] == "no-referrer"  # the token stays out of other sites' logs
        assert asyncio.run(scene_bytes(view_url(light, ada), 3.0)) > 50_000  # the apartment and robot
        # nobody watching: the robot moves and nothing is drawn (nor decoded); a viewer sees it move
        time.sleep(2 * UPDATES_PERIOD_S)  # (the counts come once a period)
        unwatched = mirrors.mirrors["light"].updates
        drive(worker, 1.0)
        time.sleep(2 * UPDATES_PERIOD_S)
        assert mirrors.mirrors["light"].updates == unwatched
        with watching(view_url(light, ada)) as received:
            wait_until(lambda: received[0] > 50_000, timeout=30)  # the scene
            scene = received[0]
            drive_until(worker, lambda: mirrors.mirrors["light"].updates > unwatched + 10)
            wait_until(lambda: received[0] > scene, timeout=10)  # and the robot moving in it
        # a shift+click on the floor: handed back with who made it (the web server decides what it may do)
        asyncio.run(shift_click(view_url(ports["full"], ada), (-2.4, -2.4, 3.0), (0.6, 0.4, -0.6)))
        wait_until(lambda: clicks, timeout=10)
        ((grant, origin, direction),) = clicks
        assert (grant.user, grant.role) == ("ada", Role.OPERATOR)
        assert origin == (-2.4, -2.4, 3.0) and direction == (0.6, 0.4, -0.6)
        # a login that ends: its token is refused from then on
        mirrors.revoke("login-ada")
        wait_until(lambda: httpx.get(f"http://127.0.0.1:{light}/s/{ada}/", timeout=10).status_code == 401, 10)
        worker.restart(EStop(source="test"))  # as the supervisor would: the mirror keeps its feed
        assert worker.submit(ReleaseEStop(source="test")).accepted
        after_restart = mirrors.mirrors["light"].updates
        bo = tokens.issue(Principal("bo", Role.VIEWER), "login-bo", time.time() + 60)
        with watching(view_url(light, bo)):
            drive_until(worker, lambda: mirrors.mirrors["light"].updates > after_restart + 10)
    finally:
        mirrors.stop()
        worker.stop()
