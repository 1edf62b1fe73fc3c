"""The far end of `humanoid bench network`: what an operator's or a viewer's browser does over the network, run
as a program of its own inside a network namespace (`ip netns exec NS python -m harness.network_client ...`).

Each scenario prints its result as one JSON line on stdout (`watch` prints one line per event as they come):
- `ready`: waits until the server answers `/api/health`;
- `rtt`: round trips of a ping on a WebSocket (`/ws/stop` carries nothing else: the link's own round trip;
  `/ws` is what the page's badge sees, behind the state stream);
- `estop`: presses the e-stop as the page does (the same message on `/ws` and `/ws/stop`, or on `/ws` alone),
  with the page's heartbeats, pings, camera and light 3D view on; each press is released once both sockets have
  acknowledged it (a late second copy would latch the robot again);
- `drive`: teleop at 10 Hz and heartbeats at 4 Hz over `/ws`, reconnecting when the socket fails, until SIGTERM;
- `watch`: the events of the given kinds, as they happen (run on the server's side of the link, where a cut
  does not reach it);
- `view`: a viewer's page at default settings (`/ws`, `/ws/camera` and the light 3D view), counting the bytes of
  each stream and the states received (a line {"measuring": true} when the measured window opens).

The login is an API token in HUMANOID_BENCH_TOKEN, sent as `Authorization: Bearer <token>` (WebSockets too).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import json
import os
import random
import signal
import sys
import time
from collections.abc import Awaitable, Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import httpx
import msgspec
import viser
import websockets
from viser._messages import ViewerCameraMessage

from robot.interface import Refusal

TOKEN_ENV = "HUMANOID_BENCH_TOKEN"
HEARTBEAT_S = 0.25  # as the page
PAGE_PING_S = 2.0  # as the page's link badge
TELEOP_PERIOD_S = 0.1
WAIT_S = 10.0
RECONNECT_S = 0.5
PRESSES = ("browser", "browser-backup")  # the sources of a page's e-stop, by the path that brought it first


def _headers() -> dict[str, str]:
    token = os.environ.get(TOKEN_ENV, "")
    return {"Authorization": f"Bearer {token}"} if token else {}


def _ws_base(base: str) -> str:
    return base.replace("https://", "wss://").replace("http://", "ws://")


def _connect(url: str, login: bool = True, **kwargs: Any) -> websockets.asyncio.client.connect:
    """`login`: with the API token (the 3D views' addresses carry their own)."""
    headers = _headers() if login else {}
    return websockets.connect(url, max_size=None, additional_headers=headers, open_timeout=WAIT_S, **kwargs)


def _emit(result: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(result) + "\n")
    sys.stdout.flush()


def _stop_on_sigterm() -> asyncio.Event:
    stop = asyncio.Event()
    asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, stop.set)
    return stop


async def _every(period_s: float, action: Callable[[], Awaitable[None]], stop: asyncio.Event) -> None:
    while not stop.is_set():
        await action()
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop.wait(), period_s)


# ready, rtt ------------------------------------------------------------------------------------------------------


def wait_ready(base: str, timeout_s: float) -> dict[str, Any]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with contextlib.suppress(httpx.HTTPError):
            if httpx.get(base + "/api/health", timeout=2.0).status_code == 200:
                return {"ready": True}
        time.sleep(0.2)
    return {"ready": False}


async def measure_rtt(base: str, path: str, count: int, period_s: float) -> dict[str, Any]:
    """Round trips of a ping (the message the page's badge sends) on `path`."""
    rtts = []
    async with _connect(_ws_base(base) + path) as ws:
        for i in range(count):
            started = time.perf_counter()
            await ws.send(json.dumps({"type": "ping", "t": i}))
            while True:  # (on /ws, the state stream comes in between)
                message = json.loads(await asyncio.wait_for(ws.recv(), WAIT_S))
                if message.get("type") == "pong" and message.get("t") == i:
                    break
            rtts.append((time.perf_counter() - started) * 1e3)
            await asyncio.sleep(period_s)
    return {"path": path, "rtt_ms": rtts}


# a viewer's streams ----------------------------------------------------------------------------------------------


@dataclass
class StreamCount:
    messages: int = 0
    bytes: int = 0
    states: int = 0  # (on /ws)


@dataclass
class PageStreams:
    """What a page is sent on each of its streams, from `started` (reset when the measured window opens)."""

    robot: StreamCount = field(default_factory=StreamCount)
    camera: StreamCount = field(default_factory=StreamCount)
    scene: StreamCount = field(default_factory=StreamCount)
    started: float = field(default_factory=time.monotonic)

    def reset(self) -> None:
        for count in (self.robot, self.camera, self.scene):  # (in place: the readers hold these)
            count.messages = count.bytes = count.states = 0
        self.started = time.monotonic()


def _count(count: StreamCount, message: str | bytes) -> None:
    count.messages += 1
    count.bytes += len(message.encode() if isinstance(message, str) else message)
    if isinstance(message, str) and _type_of(message) == "state":
        count.states += 1


def _type_of(text: str) -> str:
    """A server message's "type", read from its start (the server writes it first, with or without a space)."""
    head = text[:24].replace(" ", "")
    return head[9 : head.find('"', 9)] if head.startswith('{"type":"') else ""


async def _drain(ws: Any, count: StreamCount, on_text: Callable[[str], None] | None = None) -> None:
    async for message in ws:
        _count(count, message)
        if on_text is not None and isinstance(message, str):
            on_text(message)


async def _scene_access(base: str) -> tuple[str, int]:
    async with httpx.AsyncClient(base_url=base, headers=_headers()) as http:
        scene = (await http.get("/api/scene", timeout=WAIT_S)).json()
    return scene["token"], int(scene["ports"]["light"])


async def _open_scene(base: str, host: str, streams: PageStreams) -> None:
    """The light 3D view, as the page's frame opens it (through its gate, with a token of this login), with the
    camera message a browser sends first (viser counts a viewer from it)."""
    token, port = await _scene_access(base)
    camera = ViewerCameraMessage(
        (1.0, 0.0, 0.0, 0.0), (2.0, 2.0, 1.5), 1.0, 0.01, 100.0, 480, 640, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    )
    url = f"ws://{host}:{port}/s/{token}"
    async with _connect(url, login=False, subprotocols=[f"viser-v{viser.__version__}"]) as view:
        await view.send(msgspec.msgpack.encode(camera.as_serializable_dict()))
        await _drain(view, streams.scene)


async def _page_views(base: str, host: str, streams: PageStreams) -> None:
    """The camera stream and the light 3D view, read as fast as they come (as the page does)."""
    async with _connect(_ws_base(base) + "/ws/camera") as camera:
        await asyncio.gather(_drain(camera, streams.camera), _open_scene(base, host, streams))


def _rate(count: StreamCount, seconds: float) -> dict[str, float]:
    return {"bytes_per_s": round(count.bytes / seconds, 1), "messages_per_s": round(count.messages / seconds, 2)}


async def view(base: str, host: str, settle_s: float, seconds: float) -> dict[str, Any]:
    """A viewer's page for `settle_s` (its first scene), then `seconds` measured."""
    streams = PageStreams()
    async with _connect(_ws_base(base) + "/ws") as robot:
        tasks = [
            asyncio.create_task(_drain(robot, streams.robot)),
            asyncio.create_task(_page_views(base, host, streams)),
        ]
        await asyncio.sleep(settle_s)
        first = {name: getattr(streams, name).bytes for name in ("robot", "camera", "scene")}
        streams.reset()
        _emit({"measuring": True})  # (whoever runs this may count the link's bytes over the same window)
        await asyncio.sleep(seconds)
        window = time.monotonic() - streams.started
        counts = {name: dataclasses.replace(getattr(streams, name)) for name in ("robot", "camera", "scene")}
        failed = [repr(t.exception()) for t in tasks if t.done() and t.exception()]
        for task in tasks:
            task.cancel()
    total = sum(c.bytes for c in counts.values())
    return {
        "window_s": round(window, 2),
        "first_bytes": first,
        "streams": {name: _rate(c, window) for name, c in counts.items()},
        "bytes_per_s": round(total / window, 1),
        "state_hz": round(counts["robot"].states / window, 2),
        "camera_fps": round(counts["camera"].messages / 2 / window, 2),  # (a header and a JPEG a frame)
        "errors": failed,
    }


# the operator ----------------------------------------------------------------------------------------------------


@dataclass
class Press:
    latency_ms: float | None  # None: the robot did not latch within WAIT_S (a lost e-stop)
    source: str = ""
    server_latency_ms: float | None = None
    acked: int = 0  # sockets that acknowledged it
    sent_ms: float = 0.0  # from the press to both copies handed to the kernel


class OperatorPage:
    """The operator's `/ws` (and the e-stop's second socket) with what the page sends in the background."""

    def __init__(self, ws: Any, stop_ws: Any | None) -> None:
        self.ws = ws
        self.stop_ws = stop_ws
        self.inbox: asyncio.Queue[dict[str, Any]] = asyncio.Queue()
        self.stop_acks: asyncio.Queue[dict[str, Any]] = asyncio.Queue()
        self.streams = PageStreams()

    async def read(self) -> None:
        await _drain(self.ws, self.streams.robot, lambda text: self.inbox.put_nowait(json.loads(text)))

    async def read_stop(self) -> None:
        assert self.stop_ws is not None
        async for raw in self.stop_ws:
            self.stop_acks.put_nowait(json.loads(raw))

    async def heartbeat(self) -> None:
        await self.ws.send('{"type":"heartbeat"}')

    async def page_ping(self) -> None:
        await self.ws.send(json.dumps({"type": "ping", "t": time.time()}))

    async def next_message(self, kinds: set[str], until: float) -> dict[str, Any]:
        while (left := until - time.monotonic()) > 0:
            message = await asyncio.wait_for(self.inbox.get(), timeout=left)
            if message.get("type") in kinds:
                return message
        raise TimeoutError(f"no {sorted(kinds)} within {WAIT_S} s")

    async def press(self) -> Press:
        while not self.inbox.empty():
            self.inbox.get_nowait()
        while not self.stop_acks.empty():
            self.stop_acks.get_nowait()
        pressed = time.time()
        message = json.dumps({"type": "estop", "client_time_s": pressed})
        for ws in (self.ws, self.stop_ws):
            if ws is not None:
                await ws.send(message)
        sent_ms = (time.time() - pressed) * 1e3  # (this program's own delay, before the link has it)
        until = time.monotonic() + WAIT_S
        latched: dict[str, Any] | None = None
        acked = 0
        try:
            while latched is None or acked < 1:  # the latch (an event) and /ws's acknowledgement
                message = await self.next_message({"event", "estop_ack"}, until)
                if message["type"] == "estop_ack":
                    acked += 1
                elif message["event"]["kind"] == "estop/latched" and message["event"]["data"].get("source") in PRESSES:
                    latched = message["event"]
            if self.stop_ws is not None:  # released only once the second copy is in (else it would latch again)
                await asyncio.wait_for(self.stop_acks.get(), timeout=max(0.0, until - time.monotonic()))
                acked += 1
        except TimeoutError:
            if latched is None:
                return Press(None, acked=acked, sent_ms=sent_ms)
        data = latched["data"]
        return Press(
            float(data["latency_ms"]), str(data.get("source", "")), data.get("server_latency_ms"), acked, sent_ms
        )

    async def release(self) -> None:
        """Release, and wait for the robot's answer (sent once it has applied it: a state may be older). Asked
        again while the robot says not yet (the stop still being applied, a passing fault)."""
        until = time.monotonic() + WAIT_S
        while True:
            await self.ws.send('{"type":"estop_release"}')
            message = await self.next_message({"estop_release_ack", "error"}, until)
            if message.get("accepted") or message.get("refusal") == Refusal.NOT_LATCHED.value:
                return
            if message["type"] == "error" or time.monotonic() > until:
                raise RuntimeError(f"release refused: {message.get('message')}")
            await asyncio.sleep(0.2)


async def estop(base: str, host: str, presses: int, both: bool, views: bool, seed: int) -> dict[str, Any]:
    rng = random.Random(seed)
    stop = asyncio.Event()
    async with contextlib.AsyncExitStack() as stack:
        ws = await stack.enter_async_context(_connect(_ws_base(base) + "/ws"))
        stop_ws = await stack.enter_async_context(_connect(_ws_base(base) + "/ws/stop")) if both else None
        page = OperatorPage(ws, stop_ws)
        background = [page.read(), _every(HEARTBEAT_S, page.heartbeat, stop), _every(PAGE_PING_S, page.page_ping, stop)]
        if stop_ws is not None:
            background.append(page.read_stop())
        if views:
            background.append(_page_views(base, host, page.streams))
        tasks = [asyncio.create_task(c) for c in background]
        results: list[Press] = []
        try:
            await page.next_message({"state"}, time.monotonic() + WAIT_S)
            for _ in range(presses):
                await asyncio.sleep(rng.uniform(0.3, 0.8))  # a human's pace, not phase-locked with anything
                results.append(await page.press())
                await page.release()
        finally:
            stop.set()
            for task in tasks:
                task.cancel()
    return {"paths": "/ws + /ws/stop" if both else "/ws", "presses": [asdict(p) for p in results]}


async def drive(base: str, vx: float, yaw_rate: float) -> dict[str, Any]:
    """Teleop at 10 Hz (forward and turning), heartbeats at 4 Hz, until SIGTERM. A socket that fails (the link
    cut long enough) is opened again, as the page does."""
    stop = _stop_on_sigterm()
    sent = reconnects = refusals = 0
    reasons: set[str] = set()
    teleop_message = json.dumps({"type": "teleop", "vx": vx, "vy": 0.0, "yaw_rate": yaw_rate})
    while not stop.is_set():
        try:
            async with _connect(_ws_base(base) + "/ws") as ws:

                async def teleop(ws: Any = ws) -> None:
                    nonlocal sent
                    await ws.send(teleop_message)
                    sent += 1

                async def heartbeat(ws: Any = ws) -> None:
                    await ws.send('{"type":"heartbeat"}')

                async def refused(ws: Any = ws) -> None:
                    nonlocal refusals
                    async for raw in ws:
                        if isinstance(raw, str) and _type_of(raw) == "teleop_ack":
                            refusals += 1
                            reasons.add(str(json.loads(raw).get("message"))[:120])

                tasks = [
                    asyncio.create_task(c)
                    for c in (_every(TELEOP_PERIOD_S, teleop, stop), _every(HEARTBEAT_S, heartbeat, stop), refused())
                ]
                await asyncio.wait([*tasks, asyncio.create_task(stop.wait())], return_when=asyncio.FIRST_COMPLETED)
                for task in tasks:
                    task.cancel()
                if stop.is_set():
                    with contextlib.suppress(Exception):
                        await ws.send('{"type":"teleop_stop"}')
        except (OSError, TimeoutError, websockets.ConnectionClosed):
            pass
        if not stop.is_set():
            reconnects += 1
            await asyncio.sleep(RECONNECT_S)
    return {"teleop_sent": sent, "reconnects": reconnects, "refusals": refusals, "refused_because": sorted(reasons)}


async def watch(base: str, kinds: set[str]) -> dict[str, Any]:
    """Each event of `kinds` as one line, as it happens, until SIGTERM."""
    stop = _stop_on_sigterm()
    seen = 0
    async with _connect(_ws_base(base) + "/ws") as ws:
        _emit({"ready": True})

        async def read() -> None:
            nonlocal seen
            async for raw in ws:
                if isinstance(raw, str) and _type_of(raw) == "event":
                    event = json.loads(raw)["event"]
                    if not kinds or event["kind"] in kinds:
                        seen += 1
                        _emit({"event": event, "received_s": time.time()})

        reader = asyncio.create_task(read())
        await asyncio.wait([reader, asyncio.create_task(stop.wait())], return_when=asyncio.FIRST_COMPLETED)
        reader.cancel()
    return {"events": seen}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", choices=["ready", "rtt", "estop", "drive", "watch", "view"])
    parser.add_argument("--base", required=True, help="the server's address, e.g. http://10.36.0.1:8000")
    parser.add_argument("--timeout", type=float, default=120.0, help="ready: how long to wait")
    parser.add_argument("--path", default="/ws/stop", help="rtt: the WebSocket to ping on")
    parser.add_argument("--count", type=int, default=50, help="rtt: pings")
    parser.add_argument("--period", type=float, default=0.1, help="rtt: seconds between pings")
    parser.add_argument("--presses", type=int, default=100, help="estop: presses")
    parser.add_argument("--ws-only", action="store_true", help="estop: on /ws alone (not as the page does)")
    parser.add_argument("--no-views", action="store_true", help="estop: without the camera and 3D view")
    parser.add_argument("--seed", type=int, default=0, help="estop: seed of the pace of the presses")
    parser.add_argument("--vx", type=float, default=0.1, help="drive: forward speed (m/s)")
    parser.add_argument("--yaw-rate", type=float, default=0.3, help="drive: turn rate (rad/s)")
    parser.add_argument("--kinds", default="", help="watch: event kinds, comma-separated")
    parser.add_argument("--settle", type=float, default=5.0, help="view: seconds before measuring")
    parser.add_argument("--seconds", type=float, default=20.0, help="view: seconds measured")
    args = parser.parse_args(argv)
    host = httpx.URL(args.base).host
    if args.scenario == "ready":
        result = wait_ready(args.base, args.timeout)
    elif args.scenario == "rtt":
        result = asyncio.run(measure_rtt(args.base, args.path, args.count, args.period))
    elif args.scenario == "estop":
        result = asyncio.run(estop(args.base, host, args.presses, not args.ws_only, not args.no_views, args.seed))
    elif args.scenario == "drive":
        result = asyncio.run(drive(args.base, args.vx, args.yaw_rate))
    elif args.scenario == "watch":
        result = asyncio.run(watch(args.base, {k for k in args.kinds.split(",") if k}))
    else:
        result = asyncio.run(view(args.base, host, args.settle, args.seconds))
    _emit(result)
    return 0 if result.get("ready", True) else 1


if __name__ == "__main__":
    sys.exit(main())
