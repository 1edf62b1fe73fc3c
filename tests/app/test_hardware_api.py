"""The web app serving the real-robot backend (the servos emulated on a pseudo-terminal): torque from the API,
motion commands the bus cannot serve refused with the reason, servo diagnostics with their bus IDs, sessions."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from app.runtime import Runtime
from app.web.main import create_app
from robot.diagnostics.thresholds import Thresholds
from robot.hardware import control_table as ct
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import default_config
from robot.hardware.worker import ESTOP_TORQUE_OFF_AFTER_S, HardwareWorker
from tests.app.test_api import wait_until

# The emulated servos are a process on the same (possibly loaded) machine: a full machine paused it 200 ms at a time,
# three late replies in a row at a 100 ms margin made a servo "lost" and the robot stopped safely. A late reply
# here costs the test time only: a real servo gets 2 ms. The servos' bus watchdog at its longest (2.5 s, not 0.5 s):
# a loaded machine stalled the control loop 756 ms, the servos stopped, and the robot took it for a lost loop.
CONFIG = dataclasses.replace(default_config(), reply_margin_ms=1000.0, bus_watchdog_ms=2500)
# A loaded test machine can pause the control loop longer than the robot's 0.5 s: diagnostics would take it for a
# stalled loop and stop the robot safely (none of these tests is about that watchdog).
DIAGNOSTICS = Thresholds(control_stale_s=3.0)


DEADMAN_S = 2.0  # the page's heartbeat every 250 ms keeps torque on, with room for a loaded machine's pauses


@pytest.fixture
def hardware_client(request, settings, layout) -> Iterator[tuple[TestClient, BusEmulator]]:
    """The deadman is off unless a test asks for one (`@pytest.mark.parametrize("hardware_client", [s],
    indirect=True)`): the other tests do not heartbeat."""
    deadman_s = getattr(request, "param", 0.0)
    with BusEmulator([j.servo_id for j in CONFIG.joints]) as emulator:
        worker = HardwareWorker(
            dataclasses.replace(CONFIG, port=emulator.port_name),
            layout,
            diagnostics=DIAGNOSTICS,
            deadman_s=deadman_s,
            # the real robot's time to crouch before torque goes off: the crouch advances by control ticks, and
            # beside stress-ng the loop ticked too few in 1 s for the knee to bend visibly before torque went off
            estop_torque_off_s=ESTOP_TORQUE_OFF_AFTER_S,
        )
        runtime = Runtime.start(settings.model_copy(update={"backend": "dynamixel"}), worker=worker)
        with TestClient(create_app(settings, runtime=runtime)) as client:
            yield client, emulator
        runtime.stop()


def test_the_page_drives_the_real_robots_torque_and_is_told_what_it_cannot_do(hardware_client) -> None:
    client, emulator = hardware_client
    assert client.get("/api/state").json()["torque_enabled"] is False
    assert client.post("/api/posture", json={"posture": "stand"}).status_code == 409  # torque is off
    assert client.post("/api/torque", json={"enabled": True}).status_code == 200
    wait_until(lambda: client.get("/api/state").json()["torque_enabled"])
    assert all(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in CONFIG.joints)
    refused = client.post("/api/teleop", json={"vx": 0.1, "vy": 0.0, "yaw_rate": 0.0})
    assert refused.status_code == 501 and "IMU" in refused.json()["detail"]["message"]
    assert client.post("/api/sim/faults", json={"fault": "imu_lost"}).status_code == 501
    knee = wait_until(lambda: (d := client.get("/api/diagnostics").json())["groups"].get("servos") and d)
    ids = {s["name"]: s["hardware_id"] for s in knee["groups"]["servos"]["statuses"]}
    assert ids["servos/r_knee"] == "XM430-W350 id 13" and len(ids) == 24
    assert "power" not in knee["groups"] and "sensors/imu" not in str(knee)
    assert client.post("/api/estop").status_code == 200
    wait_until(lambda: not client.get("/api/state").json()["torque_enabled"])  # crouched, then off
    session = client.get("/api/sessions").json()["items"][0]
    assert session["backend"] == "dynamixel"


@pytest.mark.parametrize("hardware_client", [DEADMAN_S], indirect=True)
def test_torque_stays_on_only_while_the_page_heartbeats(hardware_client) -> None:
    """The browser deadman: the page's WebSocket heartbeat keeps torque on; when the page goes (closed, hung,
    cut off), the robot makes its controlled stop, then turns torque off."""
    client, emulator = hardware_client
    with client.websocket_connect("/ws") as ws:
        ws.send_json({"type": "heartbeat"})
        assert client.post("/api/torque", json={"enabled": True}).status_code == 200
        wait_until(lambda: client.get("/api/state").json()["torque_enabled"])
        for _ in range(int(1.5 * DEADMAN_S / 0.25)):  # longer than the deadman: a heartbeat every 250 ms, as the page
            ws.send_json({"type": "heartbeat"})
            time.sleep(0.25)
        state = client.get("/api/state").json()
        stops = [e["message"] for e in client.get("/api/events").json() if e["kind"] == "estop/latched"]
        assert state["torque_enabled"] and not state["estop_latched"], stops
    # the page is gone
    wait_until(lambda: client.get("/api/state").json()["estop_latched"], timeout=DEADMAN_S + 5)
    stop = next(e for e in client.get("/api/events").json() if e["kind"] == "estop/latched")
    assert stop["data"]["source"] == "deadman" and "no operator heartbeat" in stop["message"]
    wait_until(lambda: emulator.read(14, ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # l_knee: crouching
    wait_until(lambda: not client.get("/api/state").json()["torque_enabled"])
    assert not any(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in CONFIG.joints)
    # a script keeps its own heartbeat through the API
    assert client.post("/api/heartbeat").json()["accepted"] is True
