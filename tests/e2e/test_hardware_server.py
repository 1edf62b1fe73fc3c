"""`humanoid serve --backend dynamixel --port <the emulator's pty>` as a process, driven from Chromium: the page's
Torque button and its heartbeat (the deadman), the measured pose in the state the mirror draws, and the servos'
own bus watchdog stopping them when the robot's process dies with torque on."""

from __future__ import annotations

import contextlib
import dataclasses
import signal
import threading
import time
from collections.abc import Iterator

import httpx
import psutil
import pytest

from app.deploy.unit import STOP_TIMEOUT_S
from app.sessions.db import make_engine, make_session_factory
from app.sessions.models import SessionRow
from app.viz.mirror_process import MIRROR_NICE
from harness.browser import launch_chromium
from harness.server import ServerProcess
from robot.hardware import control_table as ct
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import default_config, save_config
from robot.model.world import generate_world
from robot.sim.backend import MujocoSimBackend

pytestmark = pytest.mark.slow

playwright_api = pytest.importorskip("playwright.sync_api")

KNEE_ID, KNEE_AT_START = 13, 0.3  # r_knee, bent as it was left when powered down
# The emulated servos are a process on the same (possibly loaded) machine: a full machine paused it 200 ms at a time,
# three late replies in a row at a 100 ms margin made a servo "lost" and the robot stopped safely. A late reply
# here costs the test time only: a real servo gets 2 ms.
REPLY_MARGIN_MS = 1000.0
# For the same reason the control loop, waiting on those replies, can miss its ticks for half a second (a CI run
# beside stress-ng: "control loop stale: no tick for 0.53 s", the e-stop latched before the page turned torque on):
# its staleness limit is a machine's, not a servo's, here (the stale loop's stop: tests/robot/test_diagnostics.py).
EMULATED_BUS_ENV = {"HUMANOID_DEADMAN_S": "1.5", "HUMANOID_DIAGNOSTICS__CONTROL_STALE_S": "5.0"}


def wait_until(predicate, timeout: float = 30.0):  # generous: a loaded machine
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.05)
    raise AssertionError("condition not met in time")


def test_the_real_robot_from_the_page_torque_the_measured_pose_and_the_deadman(tmp_path) -> None:
    config = default_config()
    with BusEmulator(
        [j.servo_id for j in config.joints], baudrate=2_000_000, positions={KNEE_ID: KNEE_AT_START}
    ) as emulator:
        robot_toml = tmp_path / "robot.toml"
        save_config(dataclasses.replace(config, port=emulator.port_name, reply_margin_ms=REPLY_MARGIN_MS), robot_toml)
        env = {"HUMANOID_ROBOT_CONFIG": str(robot_toml), **EMULATED_BUS_ENV}
        with ServerProcess(tmp_path / "server", extra_env=env, servo_port=emulator.port_name, views=False) as server:
            state = server.get("/api/state?qpos=true")
            assert state["torque_enabled"] is False
            scene = MujocoSimBackend(generate_world(0)).model
            knee = scene.jnt_qposadr[scene.joint("r_knee").id]
            assert state["qpos"][knee] == pytest.approx(KNEE_AT_START, abs=0.003)  # what the mirror draws

            with playwright_api.sync_playwright() as playwright:
                browser = launch_chromium(playwright)
                page = browser.new_page()
                page.goto(server.url)
                torque = page.locator("#torque")
                playwright_api.expect(torque).to_be_visible(timeout=20_000)
                torque.click()
                wait_until(lambda: server.get("/api/state")["torque_enabled"])
                assert all(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in config.joints)
                time.sleep(3.0)  # twice the deadman: the open page's heartbeat keeps torque on
                state = server.get("/api/state")
                events = [e["message"] for e in server.get("/api/events")][-8:]
                assert state["torque_enabled"] and not state["estop_latched"], events
                browser.close()  # the operator's page is gone

            wait_until(lambda: server.get("/api/state")["estop_latched"], timeout=5)
            stop = next(e for e in server.get("/api/events") if e["kind"] == "estop/latched")
            assert stop["data"]["source"] == "deadman", [e["message"] for e in server.get("/api/events")][-12:]
            wait_until(lambda: not server.get("/api/state")["torque_enabled"], timeout=8)  # crouch, then off
            assert not any(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in config.joints)


@contextlib.contextmanager
def hardware_server(tmp_path, emulator: BusEmulator) -> Iterator[ServerProcess]:
    robot_toml = tmp_path / "robot.toml"
    save_config(
        dataclasses.replace(default_config(), port=emulator.port_name, reply_margin_ms=REPLY_MARGIN_MS), robot_toml
    )
    env = {"HUMANOID_ROBOT_CONFIG": str(robot_toml), **EMULATED_BUS_ENV}
    with ServerProcess(tmp_path / "server", extra_env=env, servo_port=emulator.port_name, views=False) as server:
        yield server


@contextlib.contextmanager
def script_heartbeat(server: ServerProcess) -> Iterator[None]:
    """A script's deadman, as the page's: a heartbeat every 250 ms."""
    beating = threading.Event()
    beating.set()

    def beat() -> None:
        while beating.is_set():
            with contextlib.suppress(httpx.HTTPError):
                httpx.post(server.url + "/api/heartbeat", timeout=1.0)
            time.sleep(0.25)

    thread = threading.Thread(target=beat, daemon=True)
    thread.start()
    try:
        yield
    finally:
        beating.clear()
        thread.join(timeout=2)


def robot_process(server: ServerProcess) -> psutil.Process:
    """The robot worker's process: the server's child started by multiprocessing (not its resource tracker, nor
    the 3D mirrors' process, which runs at a lower priority)."""
    (worker,) = [
        p
        for p in psutil.Process(server.pid).children()
        if "spawn_main" in " ".join(p.cmdline()) and p.nice() != MIRROR_NICE
    ]
    return worker


def torque_on_by_script(server: ServerProcess, emulator: BusEmulator) -> None:
    assert server.post("/api/torque", json={"enabled": True}).is_success
    wait_until(lambda: server.get("/api/state")["torque_enabled"])
    assert emulator.read(KNEE_ID, ct.BUS_WATCHDOG) == default_config().bus_watchdog_ms // ct.BUS_WATCHDOG_UNIT_MS


@pytest.fixture
def torque_on(tmp_path) -> Iterator[tuple[BusEmulator, ServerProcess, psutil.Process]]:
    """The real-robot server on the emulator, torque on and a script heartbeating: (emulator, server, the robot
    worker's process)."""
    config = default_config()
    with (
        BusEmulator([j.servo_id for j in config.joints], baudrate=2_000_000) as emulator,
        hardware_server(tmp_path, emulator) as server,
        script_heartbeat(server),
    ):
        torque_on_by_script(server, emulator)
        yield emulator, server, robot_process(server)


def test_when_the_web_server_dies_the_robot_process_makes_the_controlled_stop(torque_on) -> None:
    emulator, server, worker = torque_on
    config = default_config()
    server.kill()  # SIGKILL: the web server cannot say anything
    wait_until(lambda: emulator.read(14, ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # l_knee crouching
    wait_until(lambda: not any(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in config.joints), 8)
    worker.wait(timeout=10)  # and then it exits (psutil.TimeoutExpired if not)


def test_systemctl_stop_makes_the_controlled_stop_then_the_server_exits(torque_on) -> None:
    """`systemctl stop humanoid`: the unit's KillMode=mixed sends SIGTERM to the web server alone. Its shutdown
    stops the robot the controlled way (crouch, then torque off), then everything exits cleanly, before the unit's
    stop timeout (after which systemd would kill what is left)."""
    emulator, server, worker = torque_on
    config = default_config()
    server.send_signal(signal.SIGTERM)
    wait_until(lambda: emulator.read(14, ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # l_knee crouching
    wait_until(lambda: not any(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in config.joints), 8)
    # uvicorn re-raises the SIGTERM once its graceful shutdown is done; systemd counts that as a clean exit
    assert server.wait(timeout=STOP_TIMEOUT_S) in (0, -signal.SIGTERM)
    worker.wait(timeout=5)  # the robot process has ended too (psutil.TimeoutExpired if not)
    factory = make_session_factory(make_engine(f"sqlite:///{server.workdir / 'server.db'}"))
    with factory() as db:
        (session,) = db.query(SessionRow).all()
    assert session.outcome == "ended" and session.ended_at is not None  # closed by the app, not found open


def test_when_the_robot_process_dies_the_servos_hold_then_a_new_one_takes_them_over_and_stops(torque_on) -> None:
    """Killed, the robot process stops writing: every servo's bus watchdog stops it where it is, holding (not
    limp), and the server says the robot is not driven. The supervisor then starts a new robot process, which
    finds the servos holding, takes them over where they stand and makes the controlled stop."""
    emulator, server, worker = torque_on
    config = default_config()
    worker.kill()  # the control loop dies with it: nothing writes to the bus any more
    health = wait_until(lambda: (r := httpx.get(server.url + "/api/health", timeout=5.0)).status_code == 503 and r, 3)
    assert health.json()["status"] == "worker_down"
    wait_until(lambda: all(emulator.read(j.servo_id, ct.BUS_WATCHDOG) == -1 for j in config.joints), 3)
    assert all(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in config.joints)  # holding, not limp
    knee = emulator.position_rad(KNEE_ID)
    time.sleep(0.2)
    assert emulator.position_rad(KNEE_ID) == pytest.approx(knee, abs=1e-3)
    wait_until(lambda: httpx.get(server.url + "/api/health", timeout=5.0).status_code == 200, 60)
    kinds = {e["kind"] for e in server.get("/api/events")}
    assert {"hardware/takeover", "worker/restarted"} <= kinds
    wait_until(lambda: emulator.read(14, ct.GOAL_POSITION) > ct.POSITION_CENTRE + 100)  # l_knee crouching
    wait_until(lambda: not any(emulator.read(j.servo_id, ct.TORQUE_ENABLE) for j in config.joints), 8)
