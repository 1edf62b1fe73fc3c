"""The behaviours API: list, start with parameters (422 naming a bad one), pause, resume, stop, status; typed
commands start them; a take-over by another operator pauses one; runs are kept with the session."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

import robot.robot as robot_module
from app.auth.roles import Role
from app.auth.store import UserStore
from app.runtime import Runtime
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.web.main import create_app
from robot.behaviours.api import Behaviour, Param
from robot.behaviours.registry import Registry, discover


class Count(Behaviour):
    name = "count"
    description = "count in simulated seconds"
    parameters = (Param("to", int, 3, "how far", minimum=1), Param("where", str, "", choices="places", extra=("",)))
    states = ("counting",)

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.count = 0

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        robot.wait(0.5)
        self.count += 1
        robot.feedback(str(self.count))
        return None if self.count >= self.params["to"] else "counting"


@pytest.fixture(autouse=True)
def behaviours(monkeypatch: pytest.MonkeyPatch) -> None:
    found = discover()
    registry = Registry({**found.behaviours, "count": Count}, found.packages, {})
    monkeypatch.setattr(robot_module, "discover", lambda: registry)


def wait_status(client: TestClient, state: str | None, timeout_s: float = 30.0, name: str | None = None) -> dict:
    """The status once its behaviour is in `state` (None: any) and, if given, is `name` (the status is the robot's
    published state: a start's 202 comes before the state that shows it)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        status = client.get("/api/behaviours/status").json()
        if status is not None and state in (None, status["state"]) and name in (None, status["name"]):
            return status
        time.sleep(0.05)
    raise AssertionError(f"the behaviour never became {name} {state}: {client.get('/api/behaviours/status').json()}")


def test_list_start_pause_resume_and_stop(client: TestClient) -> None:
    listed = client.get("/api/behaviours").json()
    names = {b["name"] for b in listed["behaviours"]}
    assert {"fetch", "tour", "patrol", "demo", "count"} <= names
    patrol = next(b for b in listed["behaviours"] if b["name"] == "patrol")
    assert {p["name"]: p["kind"] for p in patrol["params"]} == {"laps": "int", "waypoints": "list[str]"}
    assert listed["status"] is None

    started = client.post("/api/behaviours/count/start", json={"params": {"to": 40}})
    assert started.status_code == 202, started.json()
    deadline = time.monotonic() + 30.0
    while not wait_status(client, "running")["feedback"]:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert client.post("/api/commands", json={"text": "say hello"}).status_code == 409
    assert client.post("/api/teleop", json={"vx": 0.1}).status_code == 409
    assert client.post("/api/behaviours/pause").status_code == 200
    wait_status(client, "paused")
    assert client.post("/api/behaviours/resume").status_code == 200
    wait_status(client, "running")
    assert client.post("/api/behaviours/stop").status_code == 200
    stopped = wait_status(client, "stopped")
    assert stopped["reason"] == "stopped by the operator" and stopped["feedback"]
    assert client.post("/api/behaviours/stop").status_code == 409  # nothing left to stop
    assert client.get("/api/state").json()["behaviour"]["name"] == "count"


@pytest.mark.parametrize(
    ("name", "params", "named"),
    [
        ("patrol", {"laps": -1}, "laps"),
        ("patrol", {"laps": "lots"}, "laps"),
        ("patrol", {"waypoints": ["the garage"]}, "waypoints"),
        ("tour", {"places": ["attic"]}, "places"),
        ("fetch", {"object": "unicorn"}, "object"),
        ("fetch", {"speed": 2}, "speed"),
        ("dance", {}, "name"),
    ],
)
def test_a_bad_parameter_is_a_422_naming_it(client: TestClient, name: str, params: dict, named: str) -> None:
    reply = client.post(f"/api/behaviours/{name}/start", json={"params": params})
    assert reply.status_code == 422
    detail = reply.json()["detail"]
    assert detail["errors"][0].startswith(f"{named}:")
    assert client.get("/api/behaviours/status").json() is None


def test_typed_commands_start_and_stop_behaviours(client: TestClient) -> None:
    reply = client.post("/api/commands", json={"text": "start the count behaviour"})
    assert reply.status_code == 202 and "count started" in reply.json()["message"]
    wait_status(client, "running")
    assert client.post("/api/commands", json={"text": "stop"}).status_code == 202
    wait_status(client, "stopped")
    tour = client.post("/api/commands", json={"text": "give a tour of the kitchen"})
    assert tour.status_code == 202
    status = wait_status(client, None, name="tour")
    assert status["params"] == {"places": ["kitchen counter"]}
    failed = wait_status(client, "failed")  # this robot has no perception: it cannot walk to the kitchen
    assert "lidar" in failed["reason"]


def test_runs_are_in_the_session_timeline(client: TestClient) -> None:
    assert client.post("/api/behaviours/count/start", json={"params": {"to": 2}}).status_code == 202
    wait_status(client, "succeeded")
    session_id = client.get("/api/config").json()["session_id"]
    deadline = time.monotonic() + 20.0
    detail: dict = {}
    while time.monotonic() < deadline:
        detail = client.get(f"/api/sessions/{session_id}").json()
        if detail["behaviours"] and detail["behaviours"][0]["state"] in ("succeeded", "failed", "stopped"):
            break
        time.sleep(0.2)
    run = detail["behaviours"][0]
    assert run["name"] == "count" and run["state"] == "succeeded" and run["feedback"] == ["1", "2"]
    assert run["params"] == {"to": 2, "where": ""} and run["sim_end_s"] > run["sim_start_s"]
    shown = [item["text"] for item in detail["timeline"] if item["type"] == "behaviour"]
    assert shown[0].startswith("behaviour count started") and shown[-1] == "behaviour count succeeded"


@pytest.fixture
def two_operators(settings, make_worker) -> Iterator[tuple[TestClient, dict[str, dict[str, str]]]]:
    upgrade_to_head(settings.database_url)
    store = UserStore(make_session_factory(make_engine(settings.database_url)))
    for name in ("ada", "bob"):
        store.add(name, Role.OPERATOR, "correct horse battery")
    headers = {name: {"Authorization": f"Bearer {store.issue_token(name)}"} for name in ("ada", "bob")}
    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    with TestClient(create_app(settings, runtime=runtime)) as client:
        yield client, headers
    runtime.stop()


def test_a_take_over_pauses_the_running_behaviour(two_operators) -> None:
    client, headers = two_operators
    ada, bob = headers["ada"], headers["bob"]
    assert client.post("/api/behaviours/count/start", json={"params": {"to": 40}}, headers=ada).status_code == 202
    deadline = time.monotonic() + 30.0
    while client.get("/api/behaviours/status", headers=bob).json()["state"] != "running":
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert client.post("/api/control/take", json={"take_over": True}, headers=bob).json()["holder"] == "bob"
    deadline = time.monotonic() + 30.0
    while client.get("/api/behaviours/status", headers=bob).json()["state"] != "paused":
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert client.post("/api/behaviours/resume", headers=ada).status_code == 409  # ada no longer has control
    assert client.post("/api/behaviours/stop", headers=bob).status_code == 200


def test_a_snapshot_in_the_timeline_links_to_the_camera_frame_of_its_moment() -> None:
    from app.sessions.queries import build_timeline

    def event(seq: int, kind: str, message: str, sim_time_s: float) -> dict:
        data = {"run_id": 1}
        return {
            "seq": seq,
            "kind": kind,
            "level": 0,
            "message": message,
            "data": data,
            "wall_time": f"t{seq}",
            "sim_time_s": sim_time_s,
        }

    events = [
        event(1, "behaviour/started", "behaviour patrol started", 1.0),
        event(2, "behaviour/feedback", "lap 1", 2.0),
        event(3, "behaviour/snapshot", "a new obstacle near (0.40, 0.22)", 81.25),
    ]
    items = build_timeline([], [], [], events, session_id=7)
    assert [i["text"] for i in items] == ["behaviour patrol started", "a new obstacle near (0.40, 0.22)"]
    assert items[1]["camera_url"] == "/api/sessions/7/camera.jpg?t=81.250" and items[1]["type"] == "behaviour"
