"""Access control: users with hashed secrets, viewer and operator roles, one operator in control with explicit
take-over, no serving beyond loopback without it, and no driving from another site's page."""

from __future__ import annotations

import io
import json
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from app.auth.access import AccessControl, InsecureBind
from app.auth.roles import Role
from app.auth.secrets import WeakPassword, hash_password, verify_password
from app.auth.store import UserError, UserStore
from app.cli.commands import main
from app.runtime import Runtime
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.web.main import create_app

PASSWORD = "correct horse battery"


def user_store(settings) -> UserStore:
    upgrade_to_head(settings.database_url)
    return UserStore(make_session_factory(make_engine(settings.database_url)))


def test_passwords_are_kept_as_salted_scrypt_hashes() -> None:
    stored = hash_password(PASSWORD)
    assert PASSWORD not in stored and stored.startswith("scrypt$")
    assert stored != hash_password(PASSWORD)  # salted
    assert verify_password(PASSWORD, stored) and not verify_password("wrong horse battery", stored)
    assert not verify_password(PASSWORD, "garbage") and not verify_password(PASSWORD, "scrypt$1$2$3$!!$!!")
    with pytest.raises(WeakPassword):
        hash_password("short")


def test_users_and_tokens_in_the_database(settings) -> None:
    store = user_store(settings)
    store.add("ada", Role.OPERATOR, PASSWORD)
    with pytest.raises(UserError, match="exists"):
        store.add("ada", Role.VIEWER, PASSWORD)
    with pytest.raises(UserError):
        store.add("no spaces", Role.VIEWER, PASSWORD)
    assert store.check_password("ada", PASSWORD).role == Role.OPERATOR
    assert store.check_password("ada", "wrong horse battery") is None
    assert store.check_password("nobody", PASSWORD) is None
    token = store.issue_token("ada")
    assert store.check_token(token).name == "ada" and store.check_token(token + "x") is None
    assert store.revoke_tokens("ada") == 1 and store.check_token(token) is None
    store.set_role("ada", Role.VIEWER)
    assert store.list()[0].role == Role.VIEWER
    store.remove("ada")
    assert store.count() == 0


def test_no_serving_beyond_loopback_without_access_control(settings) -> None:
    store = user_store(settings)
    AccessControl("auto", store, "127.0.0.1").check_exposure()  # local use needs no users
    with pytest.raises(InsecureBind, match=r"refusing to serve on 0\.0\.0\.0"):
        AccessControl("auto", store, "0.0.0.0").check_exposure()
    with pytest.raises(InsecureBind, match="no users"):
        AccessControl("on", store, "127.0.0.1").check_exposure()
    with pytest.raises(InsecureBind):
        AccessControl("off", store, "192.168.1.20").check_exposure()
    store.add("ada", Role.OPERATOR, PASSWORD)
    AccessControl("auto", store, "0.0.0.0").check_exposure()


def test_serve_refuses_a_network_address_without_users_before_starting_anything(settings, monkeypatch, capsys) -> None:
    monkeypatch.setenv("DATABASE_URL", settings.database_url)
    from app.settings import get_settings

    get_settings.cache_clear()
    try:
        assert main(["serve", "--host", "0.0.0.0", "--no-mirror"]) == 2
    finally:
        get_settings.cache_clear()
    assert "without access control" in capsys.readouterr().err


@pytest.fixture
def secured(settings, make_worker) -> Iterator[tuple[TestClient, dict[str, dict[str, str]]]]:
    """The app with three users: operators ada and bob, viewer vic; their API tokens as request headers."""
    store = user_store(settings)
    for name, role in (("ada", Role.OPERATOR), ("bob", Role.OPERATOR), ("vic", Role.VIEWER)):
        store.add(name, role, PASSWORD)
    headers = {name: {"Authorization": f"Bearer {store.issue_token(name)}"} for name in ("ada", "bob", "vic")}
    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    with TestClient(create_app(settings, runtime=runtime)) as client:
        yield client, headers
    runtime.stop()


def test_nobody_gets_in_without_logging_in(secured) -> None:
    client, _ = secured
    assert client.get("/api/state").status_code == 401
    assert client.post("/api/estop", json={}).status_code == 401
    assert client.get("/metrics").status_code == 401
    assert client.get("/api/health").status_code == 200  # for monitoring
    page = client.get("/", follow_redirects=False)
    assert page.status_code in (302, 307) and page.headers["location"] == "/login"
    assert client.get("/login").status_code == 200
    for path in ("/ws", "/ws/stop", "/ws/camera"):
        with pytest.raises(WebSocketDisconnect), client.websocket_connect(path) as ws:
            ws.receive_json()


def test_login_sets_a_cookie_and_wrong_passwords_are_throttled(secured) -> None:
    client, _ = secured
    assert client.post("/api/auth/login", json={"name": "vic", "password": "wrong horse battery"}).status_code == 401
    ok = client.post("/api/auth/login", json={"name": "vic", "password": PASSWORD})
    assert ok.status_code == 200 and ok.json()["role"] == "viewer"
    cookie = ok.headers["set-cookie"].lower()
    assert "httponly" in cookie and "samesite=strict" in cookie
    assert client.get("/api/auth/me").json()["name"] == "vic"
    assert client.get("/api/state").status_code == 200
    client.post("/api/auth/logout")
    assert client.get("/api/state").status_code == 401
    for _ in range(5):
        client.post("/api/auth/login", json={"name": "bob", "password": "wrong horse battery"})
    throttled = client.post("/api/auth/login", json={"name": "bob", "password": PASSWORD})
    assert throttled.status_code == 429 and int(throttled.headers["retry-after"]) > 0


def test_a_viewer_watches_and_may_stop_but_not_drive(secured) -> None:
    client, headers = secured
    vic = headers["vic"]
    assert client.get("/api/state", headers=vic).status_code == 200
    assert client.post("/api/commands", json={"text": "say hello"}, headers=vic).status_code == 403
    assert client.post("/api/teleop", json={"vx": 0.1}, headers=vic).status_code == 403
    assert client.post("/api/estop", json={}, headers=vic).status_code == 200  # anyone who sees it may stop it
    refused = client.post("/api/estop/reset", headers=vic)
    assert refused.status_code == 403 and "operator" in refused.json()["detail"]["message"]
    assert client.delete("/api/sessions/1", headers=vic).status_code == 403
    assert client.post("/api/control/take", json={}, headers=vic).status_code == 403
    assert client.post("/api/estop/reset", headers=headers["ada"]).status_code == 200


def test_one_operator_in_control_and_take_over_is_explicit(secured) -> None:
    client, headers = secured
    ada, bob = headers["ada"], headers["bob"]
    assert client.get("/api/control", headers=bob).json()["holder"] is None
    assert client.post("/api/commands", json={"text": "say hello"}, headers=ada).status_code == 202
    assert client.get("/api/control", headers=bob).json()["holder"] == "ada"  # the first to act took it
    held = client.post("/api/commands", json={"text": "say hi"}, headers=bob)
    assert held.status_code == 409 and held.json()["detail"]["holder"] == "ada"
    assert client.post("/api/control/take", json={}, headers=bob).status_code == 409
    assert client.post("/api/control/take", json={"take_over": True}, headers=bob).json()["holder"] == "bob"
    assert client.post("/api/teleop/stop", headers=ada).status_code == 200  # stopping needs no control
    assert client.post("/api/commands", json={"text": "say hi"}, headers=ada).status_code == 409
    assert client.post("/api/control/release", headers=ada).status_code == 409  # not hers to release
    assert client.post("/api/control/release", headers=bob).json()["holder"] is None


def test_the_websocket_lets_viewers_stop_and_refuses_other_sites(secured) -> None:
    client, headers = secured
    with client.websocket_connect("/ws", headers=headers["vic"]) as ws:
        ws.receive_json()  # hello
        ws.send_json({"type": "teleop", "vx": 0.1, "vy": 0.0, "yaw_rate": 0.0})
        ws.send_json({"type": "estop", "client_time_s": None})
        seen = {}
        while "estop_ack" not in seen or "teleop_ack" not in seen:
            message = ws.receive_json()
            seen[message["type"]] = message
        assert not seen["teleop_ack"]["accepted"] and "operator" in seen["teleop_ack"]["message"]
        assert seen["estop_ack"]["accepted"]
    evil = {**headers["ada"], "Origin": "http://evil.example"}
    with pytest.raises(WebSocketDisconnect), client.websocket_connect("/ws", headers=evil) as ws:
        ws.receive_json()
    # nor a request that changes something, even with a valid login
    assert client.post("/api/estop/reset", headers=evil).status_code == 403
    assert client.post("/api/estop/reset", headers={**headers["ada"], "Origin": "http://testserver"}).status_code in (
        200,
        409,
    )


def test_users_from_the_command_line(settings, monkeypatch, capsys) -> None:
    monkeypatch.setenv("DATABASE_URL", settings.database_url)
    from app.settings import get_settings

    get_settings.cache_clear()
    try:
        monkeypatch.setattr("sys.stdin", io.StringIO(PASSWORD + "\n"))
        assert main(["users", "add", "ada", "--role", "operator", "--password-stdin"]) == 0
        monkeypatch.setattr("sys.stdin", io.StringIO("short\n"))
        assert main(["users", "add", "bob", "--role", "viewer", "--password-stdin"]) == 1
        assert "at least" in capsys.readouterr().err
        assert main(["users", "token", "ada", "--quiet"]) == 0
        token = capsys.readouterr().out.strip()
        assert main(["users", "list", "--json"]) == 0
        (ada,) = json.loads(capsys.readouterr().out)
        assert ada == {**ada, "name": "ada", "role": "operator", "password": True, "tokens": 1}
    finally:
        get_settings.cache_clear()
    assert user_store(settings).check_token(token).name == "ada"
