"""`/foxglove` on the app's own port: a WebSocket relayed to the loopback Foxglove server (app.foxglove.live), for
Foxglove and Lichtblick on other computers. The access middleware has identified the client before this runs:
with access control on, by an API token in the URL (`?token=...`: Foxglove cannot set headers), never by the
login cookie (another site's page could use that one)."""

from __future__ import annotations

import asyncio
import contextlib

import websockets
from fastapi import APIRouter, WebSocket
from starlette.websockets import WebSocketDisconnect

PATH = "/foxglove"
UPSTREAM_PROTOCOL = "foxglove.sdk.v1"  # what foxglove-sdk's server speaks
# ... and what clients may ask for: Lichtblick's older releases say foxglove.websocket.v1, whose messages are the
# same for all this server uses (serverInfo, advertise, subscribe, message data, status)
SUBPROTOCOLS = (UPSTREAM_PROTOCOL, "foxglove.websocket.v1")
SUPPORTED = set(SUBPROTOCOLS)
WS_POLICY_VIOLATION = 1008
WS_TRY_AGAIN = 1013

router = APIRouter()


@router.websocket(PATH)
async def foxglove_relay(websocket: WebSocket) -> None:
    live = getattr(websocket.app.state.runtime, "foxglove", None)
    if live is None:
        await websocket.close(WS_TRY_AGAIN, "the live Foxglove server is off: humanoid serve --foxglove-port N")
        return
    offered = [p.strip() for p in websocket.headers.get("sec-websocket-protocol", "").split(",") if p.strip()]
    chosen = next((p for p in offered if p in SUPPORTED), None)
    if chosen is None:
        await websocket.close(WS_POLICY_VIOLATION, f"speak one of {', '.join(SUBPROTOCOLS)}")
        return
    try:
        upstream = await websockets.connect(
            f"ws://127.0.0.1:{live.port}", subprotocols=[UPSTREAM_PROTOCOL], max_size=None, compression=None
        )
    except OSError:
        await websocket.close(WS_TRY_AGAIN, "the live Foxglove server does not answer")
        return
    await websocket.accept(subprotocol=chosen)
    async with upstream:
        relays = [
            asyncio.create_task(_to_client(upstream, websocket)),
            asyncio.create_task(_to_server(websocket, upstream)),
        ]
        _, pending = await asyncio.wait(relays, return_when=asyncio.FIRST_COMPLETED)
        for task in pending:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
    with contextlib.suppress(RuntimeError):
        await websocket.close()


async def _to_client(upstream: websockets.ClientConnection, websocket: WebSocket) -> None:
    with contextlib.suppress(websockets.ConnectionClosed, WebSocketDisconnect, RuntimeError):
        async for message in upstream:
            if isinstance(message, bytes):
                await websocket.send_bytes(message)
            else:
                await websocket.send_text(message)


async def _to_server(websocket: WebSocket, upstream: websockets.ClientConnection) -> None:
    with contextlib.suppress(websockets.ConnectionClosed, WebSocketDisconnect, RuntimeError):
        while True:
            message = await websocket.receive()
            if message["type"] == "websocket.disconnect":
                return
            if message.get("bytes") is not None:
                await upstream.send(message["bytes"])
            elif message.get("text") is not None:
                await upstream.send(message["text"])
