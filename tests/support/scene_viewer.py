"""What a browser does with a 3D view, done from Python: open its WebSocket and count what it is sent, or shift+click
on the floor (viser's own messages)."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Coroutine
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import msgspec
import viser
import websockets
from viser._messages import ScenePointerMessage, ViewerCameraMessage

Vector = tuple[float, float, float]
T = TypeVar("T")


def view_url(port: int, token: str, host: str = "127.0.0.1") -> str:
    """The WebSocket address of a 3D view, as a page opened with that token reaches it (through its gate)."""
    return f"ws://{host}:{port}/s/{token}"


def connect_view(url: str) -> websockets.asyncio.client.connect:
    return websockets.connect(url, max_size=None, subprotocols=[f"viser-v{viser.__version__}"])


def camera_message(origin: Vector = (-3.2, -2.8, 3.0)) -> bytes:
    """The camera message a browser sends as soon as its view opens: viser counts a viewer from it."""
    camera = ViewerCameraMessage(
        (1.0, 0.0, 0.0, 0.0), origin, 1.0, 0.01, 100.0, 480, 640, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    )
    return msgspec.msgpack.encode(camera.as_serializable_dict())


async def scene_bytes(url: str, seconds: float) -> int:
    """What a viewer's browser is sent in its first `seconds` (the scene, then its updates)."""
    received = 0
    async with connect_view(url) as viewer:
        await viewer.send(camera_message())
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            try:
                received += len(await asyncio.wait_for(viewer.recv(), timeout=left))
            except TimeoutError:
                break
    return received


async def shift_click(url: str, origin: Vector, direction: Vector) -> None:
    """What a viewer's browser sends for a shift+click in the 3D view, then stays a moment."""
    click = ScenePointerMessage("click", origin, direction, ((0.5, 0.5),), "shift")
    async with connect_view(url) as viewer:
        # viser counts a viewer as connected (and takes its clicks) from its first camera message
        await viewer.send(camera_message(origin))
        await viewer.send(msgspec.msgpack.encode(click.as_serializable_dict()))
        deadline = time.monotonic() + 1.0
        while (left := deadline - time.monotonic()) > 0:
            try:
                await asyncio.wait_for(viewer.recv(), timeout=left)
            except TimeoutError:
                break


def run_apart(coroutine: Coroutine[Any, Any, T]) -> T:
    """Run `coroutine` to its end on a thread of its own (a test thread may already run an event loop, as
    Playwright's sync API does)."""
    with ThreadPoolExecutor(max_workers=1) as pool:
        return pool.submit(asyncio.run, coroutine).result()
