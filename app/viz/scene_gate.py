"""The 3D views' front door. viser (the 3D views' server) has no login, so it listens on loopback only and every
HTTP request and WebSocket to a 3D view comes through a gate that:

- admits only addresses that carry a valid scene token (`/s/<token>/...`, see `app.auth.scene_tokens`), and hands
  viser the address without it;
- turns a click in the 3D view into a call with who clicked (`on_click`), instead of letting viser act on it with
  nobody's authority: a click is then a command like any other (operator role, control, e-stop rules);
- closes the connections of a login that ended (`revoke`);
- adds to viser's page the script that keeps an unchanged view from being redrawn every second
  (`app.viz.idle_redraw`).

It runs its own event loop on a thread of the process that serves the views (the mirrors' process for the live
views: the pages' 3D traffic never touches the web server's event loop). Scene data from viser to the browser is
copied as it comes; what the browser sends (camera moves, clicks: small) is read frame by frame.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import re
import ssl
import threading
from collections.abc import Callable

import msgspec

from app.auth.scene_tokens import SceneGrant
from app.viz.idle_redraw import (
    IDLE_REDRAW_S,
    add_script,
    content_length,
    idle_redraw_script,
    is_page,
    is_plain_ok,
    with_body,
)

log = logging.getLogger(__name__)

SCENE_PREFIX = "/s/"
MAX_HEAD_BYTES = 16 * 1024
HEAD_TIMEOUT_S = 10.0
MAX_CLIENT_MESSAGE_BYTES = 1 << 20  # what a viewer sends is small (camera moves, clicks); anything larger is refused
CLICK_MESSAGE_MAX_BYTES = 4096
PIPE_CHUNK = 1 << 16
_TOKEN = re.compile(r"[A-Za-z0-9_\-]{1,512}\.[A-Za-z0-9_\-]{1,64}")
_REFUSAL_PAGE = (
    "<!doctype html><meta charset=utf-8><title>Log in first</title>"
    "<p style='font-family:sans-serif'>This 3D view needs a login: open it from the console's page "
    "(its address carries your access).</p>"
)

Vector = tuple[float, float, float]
ClickHandler = Callable[[SceneGrant, Vector, Vector], None]


class SceneGate:
    """One public port in front of one loopback viser server."""

    def __init__(
        self,
        name: str,
        host: str,
        port: int,
        upstream_port: int,
        verify: Callable[[str], SceneGrant | None],
        on_click: ClickHandler | None = None,
        tls: ssl.SSLContext | None = None,
        idle_redraw_s: float = IDLE_REDRAW_S,
    ) -> None:
        self.name = name
        self._host = host
        self._requested_port = port
        self._upstream_port = upstream_port
        self._verify = verify
        self._on_click = on_click
        self._tls = tls
        self._page_script = idle_redraw_script(idle_redraw_s)
        self.port = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._open: dict[str, set[asyncio.StreamWriter]] = {}  # login -> its viewers' connections

    # lifecycle -------------------------------------------------------------------------------------------------

    def start(self) -> None:
        """Listen (raises OSError when the port is taken: a 3D view nobody can reach is a fault, not a detail)."""
        ready = threading.Event()
        failure: list[BaseException] = []

        def run() -> None:
            loop = asyncio.new_event_loop()
            self._loop = loop
            try:
                server = loop.run_until_complete(
                    asyncio.start_server(
                        self._serve, self._host, self._requested_port, ssl=self._tls, limit=MAX_HEAD_BYTES
                    )
                )
            except OSError as exc:
                failure.append(exc)
                ready.set()
                return
            self.port = int(server.sockets[0].getsockname()[1])
            ready.set()
            try:
                loop.run_forever()
            finally:
                server.close()
                self._close_all()
                loop.run_until_complete(_cancel_others())
                loop.close()

        self._thread = threading.Thread(target=run, name=f"scene-gate-{self.name}", daemon=True)
        self._thread.start()
        ready.wait()
        if failure:
            raise OSError(f"the {self.name} 3D view cannot listen on {self._host}:{self._requested_port}: {failure[0]}")

    def stop(self) -> None:
        if self._loop is not None and self._thread is not None and self._thread.is_alive():
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5)

    def revoke(self, login: str) -> None:
        """That login ended: its viewers are disconnected (its tokens are refused by `verify` from now on)."""
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._close_login, login)

    def _close_login(self, login: str) -> None:
        for writer in self._open.pop(login, set()):
            writer.close()

    def _close_all(self) -> None:
        for login in list(self._open):
            self._close_login(login)

    # one connection --------------------------------------------------------------------------------------------

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            await self._admit_and_relay(reader, writer)
        except (ConnectionError, OSError, asyncio.IncompleteReadError):  # the viewer went away: nothing to say
            writer.close()

    async def _admit_and_relay(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), HEAD_TIMEOUT_S)
        except (TimeoutError, asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError, ssl.SSLError):
            writer.close()
            return
        request = parse_request_head(head)
        if request is None:
            await _respond(writer, 400, "Bad Request", "malformed request")
            return
        method, target, headers = request
        admitted = admit(target, self._verify)
        if admitted is None:
            await _respond(writer, 401, "Unauthorized", _REFUSAL_PAGE, "text/html; charset=utf-8")
            return
        grant, upstream_target = admitted
        websocket = any(k == "upgrade" and v.lower() == "websocket" for k, v in headers)
        page = not websocket and method == "GET" and is_page(upstream_target)
        if page:  # asked for as is, so that the script can go in
            headers = [(k, v) for k, v in headers if k != "accept-encoding"]
        try:
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self._upstream_port)
        except OSError:
            await _respond(writer, 502, "Bad Gateway", "the 3D view is not running")
            return
        up_writer.write(build_request_head(method, target=upstream_target, headers=headers, keep_open=websocket))
        viewers = self._open.setdefault(grant.login, set())
        viewers.add(writer)
        try:
            if websocket:
                await _first_done(_copy(up_reader, writer), self._client_frames(reader, up_writer, grant))
            elif page:
                await _copy_page(up_reader, writer, self._page_script)
            else:
                await _copy_response(up_reader, writer)
        finally:
            viewers.discard(writer)
            for w in (writer, up_writer):
                w.close()

    async def _client_frames(
        self, reader: asyncio.StreamReader, upstream: asyncio.StreamWriter, grant: SceneGrant
    ) -> None:
        """What the viewer's browser sends, frame by frame: clicks are taken out and handed on with who clicked;
        everything else goes to viser unchanged."""
        held: list[bytes] = []  # the frames of a message that is not complete yet
        payload = bytearray()
        while True:
            frame, opcode, fin, body = await read_frame(reader)
            if opcode & 0x08:  # close, ping, pong: on at once, even between the fragments of a message
                upstream.write(frame)
                await upstream.drain()
                continue
            held.append(frame)
            payload += body
            if len(payload) > MAX_CLIENT_MESSAGE_BYTES:
                raise ConnectionError("a viewer's message is larger than a 3D view accepts")
            if not fin:
                continue
            if not self._take_click(bytes(payload), grant):
                for part in held:
                    upstream.write(part)
                await upstream.drain()
            held, payload = [], bytearray()

    def _take_click(self, message: bytes, grant: SceneGrant) -> bool:
        """True if `message` is a click (viser's pointer message): it goes to `on_click`, never to viser."""
        click = pointer_click(message)
        if click is None:
            return False
        if click and self._on_click is not None:
            try:
                self._on_click(grant, *click)
            except Exception:  # a failing handler must not cut the viewer off
                log.exception("3D view click handler failed")
        return True


# pure helpers (tested on their own) ------------------------------------------------------------------------------


def parse_request_head(head: bytes) -> tuple[str, str, list[tuple[str, str]]] | None:
    """(method, target, headers with lower-case names) of an HTTP/1.1 request head, or None if malformed."""
    try:
        lines = head.decode("latin-1").split("\r\n")
        method, target, version = lines[0].split(" ")
    except ValueError:
        return None
    if not version.startswith("HTTP/1.") or not target.startswith("/"):
        return None
    headers = []
    for line in lines[1:]:
        if not line:
            continue
        name, sep, value = line.partition(":")
        if not sep:
            return None
        headers.append((name.strip().lower(), value.strip()))
    return method, target, headers


def admit(target: str, verify: Callable[[str], SceneGrant | None]) -> tuple[SceneGrant, str] | None:
    """(the grant, the address for viser) when `target` is `/s/<valid token>[/rest][?query]`; else None."""
    path, sep, query = target.partition("?")
    if not path.startswith(SCENE_PREFIX):
        return None
    token, _, rest = path[len(SCENE_PREFIX) :].partition("/")
    if not _TOKEN.fullmatch(token):
        return None
    grant = verify(token)
    if grant is None:
        return None
    return grant, "/" + rest + (f"?{query}" if sep else "")


def build_request_head(method: str, target: str, headers: list[tuple[str, str]], keep_open: bool) -> bytes:
    """The request as viser gets it. A plain request is the connection's last (`Connection: close`), so that no
    second request can follow it past the gate unchecked; the referrer (which carries the token) stays here."""
    kept = [(k, v) for k, v in headers if k not in ("referer", "cookie") and (keep_open or k != "connection")]
    if not keep_open:
        kept.append(("connection", "close"))
    lines = [f"{method} {target} HTTP/1.1", *(f"{k}: {v}" for k, v in kept)]
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1")


async def read_frame(reader: asyncio.StreamReader) -> tuple[bytes, int, bool, bytes]:
    """One WebSocket frame from a client: (its raw bytes, opcode, FIN, the unmasked payload)."""
    head = await reader.readexactly(2)
    length = head[1] & 0x7F
    extended = b""
    if length == 126:
        extended = await reader.readexactly(2)
        length = int.from_bytes(extended, "big")
    elif length == 127:
        extended = await reader.readexactly(8)
        length = int.from_bytes(extended, "big")
    if length > MAX_CLIENT_MESSAGE_BYTES:
        raise ConnectionError("a viewer's frame is larger than a 3D view accepts")
    mask = await reader.readexactly(4) if head[1] & 0x80 else b""
    body = await reader.readexactly(length)
    return head + extended + mask + body, head[0] & 0x0F, bool(head[0] & 0x80), unmask(body, mask)


def unmask(data: bytes, mask: bytes) -> bytes:
    if not mask or not data:
        return data
    n = len(data)
    key = (mask * (n // 4 + 1))[:n]
    return (int.from_bytes(data, "little") ^ int.from_bytes(key, "little")).to_bytes(n, "little")


def pointer_click(message: bytes) -> tuple[Vector, Vector] | tuple[()] | None:
    """For viser's pointer message: (ray origin, ray direction) of a click, or () for another pointer event or
    a malformed one; None for any other message."""
    if len(message) > CLICK_MESSAGE_MAX_BYTES:
        return None
    try:
        decoded = msgspec.msgpack.decode(message)
    except msgspec.DecodeError:
        return None
    if not isinstance(decoded, dict) or decoded.get("type") != "ScenePointerMessage":
        return None
    origin, direction = _vector(decoded.get("ray_origin")), _vector(decoded.get("ray_direction"))
    if decoded.get("event_type") != "click" or origin is None or direction is None:
        return ()
    return origin, direction


def _vector(value: object) -> Vector | None:
    if not isinstance(value, list | tuple) or len(value) != 3:
        return None
    if not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value):
        return None
    return (float(value[0]), float(value[1]), float(value[2]))


# plumbing ------------------------------------------------------------------------------------------------------

SECURITY_HEADERS = b"Referrer-Policy: no-referrer\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n"


async def _copy(src: asyncio.StreamReader, dst: asyncio.StreamWriter) -> None:
    while data := await src.read(PIPE_CHUNK):
        dst.write(data)
        await dst.drain()


async def _copy_response(src: asyncio.StreamReader, dst: asyncio.StreamWriter) -> None:
    """viser's answer to a plain request, with headers that keep the token out of referrers and caches."""
    with contextlib.suppress(asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
        head = await src.readuntil(b"\r\n\r\n")
        dst.write(head[:-2] + SECURITY_HEADERS + b"\r\n")
        await _copy(src, dst)


async def _copy_page(src: asyncio.StreamReader, dst: asyncio.StreamWriter, script: bytes) -> None:
    """viser's page with `script` added (as `_copy_response` otherwise)."""
    with contextlib.suppress(asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
        head = await src.readuntil(b"\r\n\r\n")
        length = content_length(head)
        if length is None or not is_plain_ok(head):
            dst.write(head[:-2] + SECURITY_HEADERS + b"\r\n")
            await _copy(src, dst)
            return
        body = add_script(await src.readexactly(length), script)
        dst.write(with_body(head, body)[:-2] + SECURITY_HEADERS + b"\r\n" + body)
        await dst.drain()


async def _cancel_others() -> None:
    """Every connection's task ends with the gate."""
    tasks = [task for task in asyncio.all_tasks() if task is not asyncio.current_task()]
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)


async def _first_done(*coroutines: object) -> None:
    """Run both directions of a connection; when either ends (or fails), the connection is over."""
    tasks = [asyncio.ensure_future(c) for c in coroutines]  # type: ignore[arg-type]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task


async def _respond(writer: asyncio.StreamWriter, status: int, reason: str, body: str, kind: str = "text/plain") -> None:
    data = body.encode()
    head = (
        f"HTTP/1.1 {status} {reason}\r\nContent-Type: {kind}\r\nContent-Length: {len(data)}\r\nConnection: close\r\n"
    ).encode() + SECURITY_HEADERS
    writer.write(head + b"\r\n" + data)
    with contextlib.suppress(ConnectionError):
        await writer.drain()
    writer.close()
