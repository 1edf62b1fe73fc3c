"""Diagnostics through the API on a real (real-time) worker: faults injected into the simulation are seen at the
right level, logged with the session, and stop the robot where motion is unsafe; /metrics speaks Prometheus."""

from __future__ import annotations

import multiprocessing as mp
import time
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from prometheus_client.parser import text_string_to_metric_families

from app.runtime import Runtime
from app.web.main import create_app
from robot.diagnostics.thresholds import Thresholds
from tests.app.test_api import wait_until

# The robot's own limits, but for its control loop's watchdog: a loaded test machine can pause an in-process loop
# longer than the robot's 0.5 s, and the safe stop then refused the tests' commands or latched the e-stop they
# check is not latched. Tests of that watchdog ask for the robot's own (see `STRICT`).
THRESHOLDS = Thresholds(control_stale_s=3.0)
STRICT = pytest.mark.parametrize("client", [Thresholds()], ids=["robot-thresholds"], indirect=True)


@pytest.fixture
def client(request, settings, make_worker) -> Iterator[TestClient]:
    """The app on a real-time worker with the diagnostics thresholds a test asks for (`request.param`), else
    `THRESHOLDS`."""
    thresholds = getattr(request, "param", THRESHOLDS)
    runtime = Runtime.start(settings, worker=make_worker(realtime=True, diagnostics=thresholds))
    with TestClient(create_app(settings, runtime=runtime)) as test_client:
        test_client.runtime = runtime  # type: ignore[attr-defined]
        yield test_client
    runtime.stop()


def status(client, name: str) -> dict | None:
    body = client.get("/api/diagnostics").json()
    for group in body["groups"].values():
        for s in group["statuses"]:
            if s["name"] == name:
                return s
    return None


def wait_status(client, name: str, level: str, timeout: float = 30.0) -> dict:
    return wait_until(lambda: (s := status(client, name)) and s["level_name"] == level and s, timeout=timeout)


def inject(client, fault: str, target: str = "", value: float = 0.0):
    return client.post("/api/sim/faults", json={"fault": fault, "target": target, "value": value})


def test_every_group_is_reported_with_key_values(client) -> None:
    body = wait_until(lambda: (b := client.get("/api/diagnostics").json())["groups"].get("servos") and b)
    assert {"compute", "control", "servos", "power", "sensors", "links"} <= set(body["groups"])
    servos = body["groups"]["servos"]["statuses"]
    assert len(servos) == 24
    knee = next(s for s in servos if s["name"] == "servos/r_knee")
    for key in ("temperature_c", "current_a", "voltage_v", "load_pct", "position_error_rad", "hardware_error"):
        assert key in knee["values"]
    assert 20 < knee["values"]["temperature_c"] < 60 and knee["values"]["voltage_v"] == 12.0
    cpu = status(client, "compute/cpu")
    assert cpu["values"]["cores"] >= 1 and "core0_pct" in cpu["values"]
    battery = status(client, "power/battery")
    assert battery["level_name"] == "OK" and 20 < battery["values"]["voltage_v"] < 25.3
    assert status(client, "links/robot_worker")["level_name"] == "OK"
    assert status(client, "links/planner")["message"].startswith("rules")
    assert status(client, "control/loop")["values"]["rate_hz"] == 100.0
    assert body["level_name"] in ("OK", "WARN")  # a busy test machine may run its CPU hot
    assert body["monitor_cpu_ms"] > 0


def test_an_overheating_servo_stops_the_robot_until_it_cools(client) -> None:
    # to 77 C: past the diagnostics' limit (75), short of the servo's own shutdown (80)
    heat = 77.0 - wait_until(lambda: status(client, "servos/r_knee"))["values"]["temperature_c"]
    assert inject(client, "servo_heat", "r_knee", heat).status_code == 200
    hot = wait_status(client, "servos/r_knee", "ERROR")
    assert hot["message"] == "overheating: 77 C (limit 75)" and hot["stops_motion"]
    state = wait_until(lambda: (s := client.get("/api/state").json())["estop_latched"] and s)
    assert state["mode"] == "estop"
    latched = wait_until(lambda: [e for e in client.get("/api/events").json() if e["kind"] == "estop/latched"])
    assert "servos/r_knee" in latched[-1]["message"] and latched[-1]["data"]["source"] == "diagnostics"
    refused = client.post("/api/estop/reset")
    assert refused.status_code == 409 and "r_knee" in refused.json()["detail"]["message"]
    assert client.post("/api/commands", json={"text": "say hello"}).status_code == 409
    # cooled (a fan put on it): the alarm clears at the next sample and the operator may release the stop
    assert inject(client, "servo_heat", "r_knee", -heat).status_code == 200
    wait_status(client, "servos/r_knee", "OK")
    wait_until(lambda: client.post("/api/estop/reset").status_code == 200)
    kinds = [e["kind"] for e in client.get("/api/events").json()]
    assert "diagnostics/alarm" in kinds and "diagnostics/safe_stop" in kinds and "diagnostics/recovered" in kinds


def test_a_jammed_servo_trips_its_overload_protection(client) -> None:
    inject(client, "servo_overload", "l_ank_pitch", 100)
    jammed = wait_status(client, "servos/l_ank_pitch", "ERROR")  # held 3 s at stall, then sampled
    assert "overload" in jammed["message"] and jammed["values"]["hardware_error"] & 0x20
    wait_until(lambda: client.get("/api/state").json()["estop_latched"])
    inject(client, "clear")  # the jam removed, the servo rebooted: its error bit clears
    wait_status(client, "servos/l_ank_pitch", "OK")


def test_a_lost_imu_stops_the_robot(client) -> None:
    inject(client, "imu_lost")
    imu = wait_status(client, "sensors/imu", "ERROR")
    assert "IMU lost" in imu["message"] and imu["stops_motion"]
    wait_until(lambda: client.get("/api/state").json()["estop_latched"])
    assert client.post("/api/estop/reset").status_code == 409
    inject(client, "clear")
    wait_status(client, "sensors/imu", "OK")
    wait_until(lambda: client.post("/api/estop/reset").status_code == 200)


@STRICT
def test_a_stalled_control_loop_is_caught_by_the_watchdog(client) -> None:
    wait_until(lambda: status(client, "control/loop"))
    inject(client, "control_stall", value=0.8)  # past the robot's 0.5 s
    wait_until(lambda: client.get("/api/state").json()["estop_latched"])
    events = client.get("/api/events").json()
    stop = next(e for e in events if e["kind"] == "diagnostics/safe_stop")
    assert "control loop stale" in stop["message"]
    # ticking again: no longer an ERROR (a WARN for the deadlines it missed may follow), so it may be released
    wait_until(lambda: status(client, "control/loop")["level_name"] in ("OK", "WARN"))
    wait_until(lambda: client.post("/api/estop/reset").status_code == 200)


def test_a_low_battery_is_an_alarm_not_a_stop(client) -> None:
    inject(client, "battery_soc", value=0.15)
    low = wait_status(client, "power/battery", "WARN")
    assert "battery low" in low["message"]
    inject(client, "battery_soc", value=0.05)
    critical = wait_status(client, "power/battery", "ERROR")
    assert "critical" in critical["message"] and not critical["stops_motion"]
    # past the next sample (a safe stop would come with the sample that raised the alarm): 1.2 s of simulated time,
    # at least as long in real time
    alarmed_at = client.get("/api/state").json()["sim_time_s"]
    wait_until(lambda: client.get("/api/state").json()["sim_time_s"] >= alarmed_at + 1.2)
    stops = [e["message"] for e in client.get("/api/events").json() if e["kind"] == "diagnostics/safe_stop"]
    assert not any("power/battery" in stop for stop in stops), stops


def test_alarms_are_logged_in_the_session(client) -> None:
    inject(client, "battery_soc", value=0.15)
    wait_status(client, "power/battery", "WARN")
    session_id = client.runtime.recorder.session_id

    def alarm_in_timeline():
        detail = client.get(f"/api/sessions/{session_id}").json()
        return [i for i in detail["timeline"] if i["type"] == "alarm" and "power/battery" in i["text"]]

    wait_until(alarm_in_timeline)


def test_fault_injection_rejects_what_makes_no_sense(client) -> None:
    assert inject(client, "servo_heat", "tail", 10).status_code == 422
    assert inject(client, "melt").status_code == 422
    assert client.post("/api/sim/faults", json={"fault": "battery_soc", "value": "nan"}).status_code == 422
    assert inject(client, "battery_soc", value=7).status_code == 422


def test_metrics_speak_prometheus(client) -> None:
    wait_until(lambda: status(client, "servos/r_knee"))
    response = client.get("/metrics")
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/plain")
    families = {f.name: f for f in text_string_to_metric_families(response.text)}
    levels = {s.labels["name"]: s.value for s in families["humanoid_diagnostic_level"].samples}
    assert levels["servos/r_knee"] in (0, 1) and "control/loop" in levels
    temps = {s.labels["name"]: s.value for s in families["humanoid_servos_temperature_c"].samples}
    assert len(temps) == 24 and 20 < temps["r_knee"] < 60
    assert families["humanoid_power_voltage_v"].samples[0].value > 20


def test_browsers_connected_are_counted(client) -> None:
    with client.websocket_connect("/ws") as ws:
        ws.receive_json()  # hello
        assert status(client, "links/browsers")["values"]["clients"] == 1
        for _ in range(200):  # the socket sends diagnostics once a second among the states
            message = ws.receive_json()
            if message["type"] == "diagnostics":
                assert "servos" in message["diagnostics"]["groups"]
                break
        else:
            raise AssertionError("no diagnostics over the WebSocket")
    wait_until(lambda: status(client, "links/browsers")["values"]["clients"] == 0)


def _burn(seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pass


def test_cpu_overload_is_a_warning(served) -> None:
    """Every core busy for several seconds (real load, not a pretend reading). With the robot in the test's own
    process its control thread waited for the interpreter lock held by threads the burners had pre-empted, and
    the watchdog stopped the robot now and then: served, the robot has its own process, as here."""
    client = served
    burners = [mp.get_context("spawn").Process(target=_burn, args=(8.0,)) for _ in range(mp.cpu_count())]
    for b in burners:
        b.start()
    try:
        cpu = wait_status(client, "compute/cpu", "WARN", timeout=9)
        assert "CPU overloaded" in cpu["message"]
        assert not client.get("/api/state").json()["estop_latched"]  # busy is not unsafe
    finally:
        for b in burners:
            b.kill()
            b.join()


def test_a_silent_robot_worker_turns_its_statuses_stale(settings) -> None:
    """The robot's statuses are only as good as their last report: the server marks them STALE when it stops."""
    from types import SimpleNamespace

    from app.diagnostics import diagnostics_json, snapshot
    from app.sessions.recorder import WriteStats
    from robot.interface import DiagnosticArray, DiagnosticStatus, Level

    old = DiagnosticArray(time.time() - 10, 42.0, (DiagnosticStatus("servos/r_knee", Level.OK, "40 C, 12 % load"),))
    worker = SimpleNamespace(diagnostics=lambda: old, is_alive=lambda: False)
    recorder = SimpleNamespace(stats=WriteStats(), backlog=lambda: 0, session_id=7)
    rt = SimpleNamespace(worker=worker, recorder=recorder, settings=settings, browser_clients=0, supervisor=None)
    body = diagnostics_json(snapshot(rt))
    knee = body["groups"]["servos"]["statuses"][0]
    assert knee["level_name"] == "STALE" and knee["message"].startswith("no report from the robot for 10 s")
    worker_link = next(s for s in body["groups"]["links"]["statuses"] if s["name"] == "links/robot_worker")
    assert worker_link["level_name"] == "ERROR" and body["level_name"] == "ERROR"
