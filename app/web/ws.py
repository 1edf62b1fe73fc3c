"""WebSocket `/ws`: state and events out, e-stop in (the fastest path from a browser press to the robot), and
`/ws/stop`: the e-stop's second path (see `stop_socket`).

Messages from the server: {"type": "hello", ...}, {"type": "state", "state": ...}, {"type": "event", "event": ...},
{"type": "diagnostics", "diagnostics": ...} (once a second, as GET /api/diagnostics),
{"type": "estop_ack", ...}, {"type": "error", "message": ...}.
Messages to the server: {"type": "estop", "client_time_s": float | null}, {"type": "estop_release"},
{"type": "teleop", "vx": float, "vy": float, "yaw_rate": float} (repeat every 100 ms while driving; a refusal
is answered with {"type": "teleop_ack", ...}), {"type": "teleop_stop"}, {"type": "ping", "t": any},
{"type": "heartbeat"} (the page sends one every 250 ms: on the real robot torque stays on only while an operator
heartbeats, see `OperatorHeartbeat`; not answered).
A socket that drove the robot stops it when it closes: the browser's connection is part of the deadman.
With access control on, anyone connected may press the e-stop and stop teleop; releasing the e-stop and driving
need an operator in control (refused with {"type": "error", ...}), and a heartbeat counts only from the operator
in control. {"type": "control", "control": {"holder": name | null, "since": t}} says who operates, when it
changes.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import time
from typing import Any

from fastapi import APIRouter, WebSocket, WebSocketDisconnect

from app.auth.control import operator_refusal
from app.auth.roles import LOCAL_OPERATOR, Principal
from app.runtime import Runtime
from app.web.api.robot import TELEOP_MAX_SPEED_M_S, TELEOP_MAX_YAW_RATE
from app.web.browser_feed import BrowserFeed
from app.web.robot_calls import ask, tell
from app.web.serialize import event_json, reply_json
from robot.interface import Command, EStop, OperatorHeartbeat, ReleaseEStop, StopTeleop, Teleop

router = APIRouter()
MAX_MESSAGE_BYTES = 4096
BACKUP_SOURCE = "browser-backup"  # an e-stop that came in on the page's second socket first
_ANSWERS: set[asyncio.Task] = set()  # replies on their way to pages (kept referenced until they are sent)


def _client_time(message: dict[str, Any]) -> float | None:
    value = message.get("client_time_s")
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    return None


def _number(message: dict[str, Any], key: str, bound: float) -> float:
    value = message.get(key, 0.0)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{key} must be a finite number")
    if abs(value) > bound:
        raise ValueError(f"{key} {value:g} is beyond {bound:g}: refused")
    return float(value)


def _counts_as_heartbeat(rt: Runtime, who: Principal) -> bool:
    if rt.access is None or not rt.access.enabled:
        return True
    holder = rt.control.holder
    return holder is not None and holder.name == who.name


async def _receive(ws: WebSocket, rt: Runtime, drove: list[bool], who: Principal) -> None:
    while True:
        raw = await ws.receive_text()
        if len(raw) > MAX_MESSAGE_BYTES:
            await ws.send_json({"type": "error", "message": f"message larger than {MAX_MESSAGE_BYTES} bytes"})
            continue
        try:
            message = json.loads(raw)
            kind = message["type"]
        except (ValueError, KeyError, TypeError):
            await ws.send_json({"type": "error", "message": "expected a JSON object with a 'type'"})
            continue
        if kind == "estop":
            command = EStop(source="browser", client_time_s=_client_time(message), relayed_at_s=time.time())
            _answer_later(ws, rt, command, "estop_ack", server_time=True)
        elif kind == "estop_release":
            if refusal := operator_refusal(rt.control, who):
                await ws.send_json({"type": "estop_release_ack", "accepted": False, "message": refusal})
                continue
            _answer_later(ws, rt, ReleaseEStop(source="browser"), "estop_release_ack")
        elif kind == "teleop":
            try:
                velocity = (
                    _number(message, "vx", TELEOP_MAX_SPEED_M_S),
                    _number(message, "vy", TELEOP_MAX_SPEED_M_S),
                    _number(message, "yaw_rate", TELEOP_MAX_YAW_RATE),
                )
            except ValueError as exc:
                await ws.send_json({"type": "teleop_ack", "accepted": False, "message": str(exc)})
                continue
            if refusal := operator_refusal(rt.control, who):
                await ws.send_json({"type": "teleop_ack", "accepted": False, "message": refusal})
                continue
            drove[0] = True  # (a refused one changes nothing: stopping on close is harmless)
            _answer_later(ws, rt, Teleop(*velocity, source="browser"), "teleop_ack", only_refusals=True)
        elif kind == "teleop_stop":
            tell(rt.worker, StopTeleop(source="browser"))
        elif kind == "heartbeat":
            if _counts_as_heartbeat(rt, who):
                tell(rt.worker, OperatorHeartbeat(source="browser"))
        elif kind == "ping":
            await ws.send_json({"type": "pong", "t": message.get("t"), "server_time_s": time.time()})
        else:
            await ws.send_json({"type": "error", "message": f"unknown message type {kind!r}"})


def _answer_later(
    ws: WebSocket, rt: Runtime, command: Command, ack: str, server_time: bool = False, only_refusals: bool = False
) -> None:
    """Send `command` now and answer the page when the robot replies, in a task of its own: the next message (an
    e-stop after a teleop, say) is read at once, whatever the robot process is doing."""

    async def answer() -> None:
        reply = await ask(rt.worker, command)
        if only_refusals and reply.accepted:
            return
        extra = {"server_time_s": time.time()} if server_time else {}
        with contextlib.suppress(Exception):  # the page may have gone meanwhile (each server says so its own way)
            await ws.send_json({"type": ack, **extra, **reply_json(reply)})

    task = asyncio.get_running_loop().create_task(answer())
    _ANSWERS.add(task)
    task.add_done_callback(_ANSWERS.discard)


async def _send(ws: WebSocket, rt: Runtime, feed: BrowserFeed) -> None:
    """The feed's texts (encoded once for every page) and this page's own events, at the feed's rate. A page that
    reads slowly skips states, it never queues them."""
    subscription = rt.worker.subscribe()
    seen = diagnostics_seen = control_seen = 0
    try:
        while True:
            if feed.control_version != control_seen:
                control_seen = feed.control_version
                await ws.send_text(feed.control)
            while (event := subscription.get(timeout=0)) is not None:
                await ws.send_json({"type": "event", "event": event_json(event)})
            await ws.send_text(feed.state)
            if feed.diagnostics_version != diagnostics_seen:  # once a second, as they are sampled
                diagnostics_seen = feed.diagnostics_version
                await ws.send_text(feed.diagnostics)
            seen = await feed.next(seen)
    finally:
        subscription.close()


def _feed(ws: WebSocket, rt: Runtime) -> BrowserFeed:
    feed = getattr(ws.app.state, "browser_feed", None)
    if feed is None:
        feed = ws.app.state.browser_feed = BrowserFeed(rt, rt.settings.ws_state_hz)
    return feed


@router.websocket("/ws")
async def robot_socket(ws: WebSocket) -> None:
    rt: Runtime = ws.app.state.runtime
    await ws.accept()
    await ws.send_json(
        {
            "type": "hello",
            "session_id": rt.recorder.session_id,
            "recent_events": [event_json(e) for e in rt.worker.recent_events()[-100:]],
        }
    )
    drove = [False]  # whether this socket has driven the robot (then its closing stops it)
    who = ws.scope.get("state", {}).get("principal") or LOCAL_OPERATOR  # (identified by the access middleware)
    rt.browser_clients += 1
    feed = _feed(ws, rt)
    feed.join()
    tasks = [asyncio.create_task(_receive(ws, rt, drove, who)), asyncio.create_task(_send(ws, rt, feed))]
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            if (exc := task.exception()) and not isinstance(exc, WebSocketDisconnect):
                raise exc
    except WebSocketDisconnect:
        pass
    finally:
        rt.browser_clients -= 1
        feed.leave()
        for task in tasks:
            task.cancel()
        if drove[0]:
            tell(rt.worker, StopTeleop(source="browser-disconnect"))


@router.websocket("/ws/stop")
async def stop_socket(ws: WebSocket) -> None:
    """A second way in for the e-stop, on a TCP connection of its own: the page sends every press on `/ws` and
    here. A segment lost on one connection waits ~200 ms for its resend (a second over a bad link); both lost
    together is the square of that chance. Takes {"type": "estop", "client_time_s": ...} and pings only."""
    rt: Runtime = ws.app.state.runtime
    await ws.accept()
    with contextlib.suppress(WebSocketDisconnect):
        while True:
            raw = await ws.receive_text()
            try:
                message = json.loads(raw) if len(raw) <= MAX_MESSAGE_BYTES else {}
                kind = message["type"]
            except (ValueError, KeyError, TypeError):
                kind = None
            if kind == "estop":
                command = EStop(source=BACKUP_SOURCE, client_time_s=_client_time(message), relayed_at_s=time.time())
                _answer_later(ws, rt, command, "estop_ack", server_time=True)
            elif kind == "ping":
                await ws.send_json({"type": "pong", "t": message.get("t"), "server_time_s": time.time()})
            else:
                await ws.send_json({"type": "error", "message": "this socket takes e-stops and pings only"})
