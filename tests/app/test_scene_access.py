"""The 3D views (live full and light, session replay) open only with a token of a login; their clicks are commands
of whoever clicked; a login that ends closes its views."""

from __future__ import annotations

import asyncio
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import msgspec
import pytest
import viser
import websockets
from fastapi.testclient import TestClient
from viser._messages import ScenePointerMessage, ViewerCameraMessage

from app.auth.roles import Principal, Role
from app.auth.scene_tokens import SceneTokens
from app.runtime import Runtime
from app.viz.idle_redraw import (
    IDLE_REDRAW_S,
    add_script,
    content_length,
    idle_redraw_script,
    is_page,
    is_plain_ok,
    with_body,
)
from app.viz.scene_gate import admit, build_request_head, parse_request_head, pointer_click, unmask
from app.web.api.scene import other_site
from app.web.main import create_app
from harness.server import free_port
from tests.app.test_access import PASSWORD, user_store
from tests.app.test_api import wait_until
from tests.support.scene_viewer import scene_bytes, shift_click, view_url

ADA = Principal("ada", Role.OPERATOR)


def test_tokens_are_signed_expire_and_die_with_their_login() -> None:
    tokens = SceneTokens()
    token = tokens.issue(ADA, "login-1", time.time() + 60)
    grant = tokens.verify(token)
    assert grant is not None and grant.principal == ADA and grant.login == "login-1"
    payload, _, signature = token.partition(".")
    forged = SceneTokens().issue(Principal("ada", Role.OPERATOR), "login-1", time.time() + 60)
    viewer_made_operator = SceneTokens(tokens.secret).issue(Principal("vic", Role.VIEWER), "l", time.time() + 60)
    assert tokens.verify(forged) is None  # another server's secret
    assert tokens.verify(payload + "." + signature[::-1]) is None
    assert tokens.verify(viewer_made_operator.partition(".")[0] + "." + signature) is None  # payload swapped
    assert tokens.verify("garbage") is None and tokens.verify("") is None
    assert tokens.verify(token, now=time.time() + 61) is None  # expired
    tokens.revoke("login-1")
    assert tokens.verify(token) is None


def test_the_gate_reads_requests_and_viewer_messages_as_they_come() -> None:
    head = b"GET /s/abc.def/?fixedDpr=0.5 HTTP/1.1\r\nHost: localhost:8082\r\nReferer: http://x/s/abc.def/\r\n\r\n"
    method, target, headers = parse_request_head(head)
    assert (method, target) == ("GET", "/s/abc.def/?fixedDpr=0.5") and ("host", "localhost:8082") in headers
    assert parse_request_head(b"nonsense\r\n\r\n") is None and parse_request_head(b"GET x HTTP/1.1\r\n\r\n") is None
    tokens = SceneTokens()
    token = tokens.issue(ADA, "l", time.time() + 60)
    grant, upstream = admit(f"/s/{token}/?fixedDpr=0.5", tokens.verify)
    assert grant.user == "ada" and upstream == "/?fixedDpr=0.5"
    assert admit(f"/s/{token}", tokens.verify)[1] == "/"  # viser's WebSocket address (no trailing slash)
    assert admit("/", tokens.verify) is None and admit("/s/../index.html", tokens.verify) is None
    forwarded = build_request_head("GET", "/", headers, keep_open=False).decode()
    assert "referer" not in forwarded.lower() and forwarded.endswith("connection: close\r\n\r\n")
    message = b"hello, viewer" * 7
    assert unmask(unmask(message, b"\x01\x02\x03\x04"), b"\x01\x02\x03\x04") == message
    camera = ViewerCameraMessage((1.0, 0, 0, 0), (0, 0, 1.0), 1.0, 0.01, 100.0, 480, 640, (0, 0, 0), (0, 0, 1.0))
    click = ScenePointerMessage("click", (1.0, 2.0, 3.0), (0.0, 0.0, -1.0), ((0.5, 0.5),), "shift")
    assert pointer_click(msgspec.msgpack.encode(click.as_serializable_dict())) == ((1.0, 2.0, 3.0), (0.0, 0.0, -1.0))
    assert pointer_click(msgspec.msgpack.encode(camera.as_serializable_dict())) is None  # goes on to viser
    no_ray = ScenePointerMessage("click", None, None, ((0.5, 0.5),), "shift")
    assert pointer_click(msgspec.msgpack.encode(no_ray.as_serializable_dict())) == ()  # taken, but no command
    assert pointer_click(b"\xc1 not msgpack") is None


def test_the_views_open_on_another_name_of_the_server_than_the_page() -> None:
    assert other_site("127.0.0.1", "127.0.0.1") == "localhost" and other_site("localhost", "127.0.0.1") == "127.0.0.1"
    assert other_site("robot.local", "192.168.1.20") == "192.168.1.20"  # the address the browser reached
    assert other_site("robot.local", "fe80::1") == "[fe80::1]"
    assert other_site("192.168.1.20", "192.168.1.20") == socket.gethostname()


@pytest.fixture
def secured_views(settings, make_worker) -> Iterator[tuple[TestClient, Runtime]]:
    """Access control on (operator ada, viewer vic) and the three 3D views served, behind their gates."""
    store = user_store(settings)
    for name, role in (("ada", Role.OPERATOR), ("vic", Role.VIEWER)):
        store.add(name, role, PASSWORD)
    ports = {"viser_port": free_port(), "viser_light_port": free_port(), "replay_port": free_port()}
    settings = settings.model_copy(update={"enable_mirror": True, **ports})
    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    with TestClient(create_app(settings, runtime=runtime)) as client:
        yield client, runtime
    runtime.stop()


def login(client: TestClient, name: str) -> dict:
    assert client.post("/api/auth/login", json={"name": name, "password": PASSWORD}).status_code == 200
    return client.get("/api/scene").json()


def test_no_3d_view_opens_without_a_login_and_a_viewer_cannot_walk_the_robot(secured_views) -> None:
    client, rt = secured_views
    ports = [rt.scene_port(view) for view in ("full", "light", "replay")]
    assert all(ports) and client.get("/api/scene").status_code == 401
    for port in ports:
        assert httpx.get(f"http://127.0.0.1:{port}/", timeout=10).status_code == 401
        with pytest.raises(websockets.InvalidStatus):
            asyncio.run(scene_bytes(f"ws://127.0.0.1:{port}", 1.0))
    vic = login(client, "vic")
    assert vic["ports"] == {"full": ports[0], "light": ports[1], "replay": ports[2]}
    for port in ports:
        assert httpx.get(f"http://127.0.0.1:{port}/s/{vic['token']}/", timeout=10).status_code == 200
    floor = ((-2.4, -2.4, 3.0), (0.6, 0.4, -0.6))
    asyncio.run(shift_click(view_url(ports[0], vic["token"]), *floor))
    refused = wait_until(lambda: next((e for e in rt.worker.recent_events() if e.kind == "mirror/click_refused"), 0))
    assert "vic" in refused.message and "viewers may watch" in refused.message
    assert rt.worker.state().plan is None
    client.post("/api/auth/logout")
    gone = f"http://127.0.0.1:{ports[1]}/s/{vic['token']}/"
    assert httpx.get(gone, timeout=10).status_code == 401  # the login ended, its views with it
    ada = login(client, "ada")
    asyncio.run(shift_click(view_url(ports[0], ada["token"]), *floor))
    plan = wait_until(lambda: rt.worker.state().plan, timeout=10)
    assert "clicked in the 3D view" in plan.command_text and rt.control.holder.name == "ada"


def test_every_3d_view_page_carries_the_script_that_stops_redrawing_an_unchanged_scene_every_second(
    secured_views,
) -> None:
    client, rt = secured_views
    ada = login(client, "ada")
    shipped = (Path(viser.__file__).parent / "client" / "build" / "index.html").read_bytes()
    for view in ("full", "light", "replay"):
        response = httpx.get(
            f"http://127.0.0.1:{rt.scene_port(view)}/s/{ada['token']}/?fixedDpr=0.5",
            headers={"Accept-Encoding": "gzip"},  # as browsers ask: viser would compress it
            timeout=10,
        )
        assert response.status_code == 200 and response.headers["content-encoding"] == "identity"
        assert int(response.headers["content-length"]) == len(response.content)
        # viser's page unchanged but for the script, which runs before the client's own code
        assert response.content == add_script(shipped, idle_redraw_script(IDLE_REDRAW_S))
        assert response.content.index(b"__humanoidIdleRedraw") < response.content.index(b"<script data-p")
        assert response.headers["cache-control"] == "no-store"


def test_the_page_script_goes_only_into_a_plain_page_and_keeps_its_length_right() -> None:
    script = idle_redraw_script(30)
    assert b"everyMs: 30000" in script
    with pytest.raises(ValueError):
        idle_redraw_script(0.5)  # more often than viser's own 1 s is no saving
    assert add_script(b"<html><head><title>v</title></head></html>", b"<s>") == (
        b"<html><head><s><title>v</title></head></html>"
    )
    assert add_script(b"<p>no head</p>", b"<s>") == b"<s><p>no head</p>"
    head = b"HTTP/1.1 200 OK\r\nContent-Type: text/html\r\nContent-Length: 5\r\n\r\n"
    assert content_length(head) == 5 and is_plain_ok(head)
    assert content_length(with_body(head, b"1234567")) == 7
    assert with_body(head, b"1234567").startswith(b"HTTP/1.1 200 OK\r\nContent-Type: text/html\r\n")
    assert not is_plain_ok(head.replace(b"Content-Length", b"Content-Encoding: gzip\r\nContent-Length"))
    assert not is_plain_ok(b"HTTP/1.1 404 NOT FOUND\r\nContent-Length: 9\r\n\r\n")
    assert content_length(b"HTTP/1.1 200 OK\r\nContent-Length: x\r\n\r\n") is None
    assert is_page("/") and is_page("/?fixedDpr=0.5") and is_page("/index.html") and not is_page("/assets/a.js")
