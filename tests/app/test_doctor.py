"""`humanoid doctor`: every check has a level, a detail and a fix; a broken machine (a serial device this user may
not open, a slow latency timer, no real-time scheduling, a port taken, an LLM server down...) is reported with its
fix and an exit code, never a traceback. As root every permission check passes, so the unprivileged cases run in
a child process that has dropped to `nobody`, or with the kernel's access check stood in for."""

from __future__ import annotations

import grp
import json
import os
import socket
import sqlite3
import subprocess
import sys
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from app.deploy.doctor import devices, services, system
from app.deploy.doctor.report import Level, Machine, run_checks
from app.sessions.db import upgrade_to_head
from app.settings import Settings
from harness.server import free_port

HUMANOID = Path(sys.executable).parent / "humanoid"


def _settings(tmp_path: Path, **changes: object) -> Settings:
    base = {
        "database_url": f"sqlite:///{tmp_path / 'humanoid.db'}",
        "audio_dir": str(tmp_path / "audio"),
        "robot_config": str(tmp_path / "robot.toml"),
        "port": free_port(),
        "viser_port": free_port(),
        "viser_light_port": free_port(),
        "replay_port": free_port(),
    }
    return Settings().model_copy(update={**base, **changes})


@pytest.fixture
def serial_device() -> Iterator[str]:
    """A pseudo-terminal standing for the U2D2, owned root:dialout, mode 660 (as udev makes /dev/ttyUSB0)."""
    leader, follower = os.openpty()
    path = os.ttyname(follower)
    os.chown(path, 0, grp.getgrnam("dialout").gr_gid)
    os.chmod(path, 0o660)
    yield path
    os.close(follower)
    os.close(leader)


def _doctor(tmp_path: Path, *args: str, **env: str) -> tuple[int, dict, str]:
    environment = {
        **os.environ,
        "DATABASE_URL": f"sqlite:///{tmp_path / 'cli.db'}",
        "HUMANOID_AUDIO_DIR": str(tmp_path / "audio"),
        "HUMANOID_ROBOT_CONFIG": str(tmp_path / "robot.toml"),
        "PORT": str(free_port()),
        "HUMANOID_VISER_PORT": str(free_port()),
        "HUMANOID_VISER_LIGHT_PORT": str(free_port()),
        "HUMANOID_REPLAY_PORT": str(free_port()),
        **env,
    }
    done = subprocess.run(
        [str(HUMANOID), "doctor", "--json", *args], capture_output=True, text=True, timeout=300, env=environment
    )
    assert "Traceback" not in done.stdout + done.stderr
    return done.returncode, json.loads(done.stdout), done.stderr


def test_doctor_json_reports_every_check_with_a_level_a_detail_and_a_fix(tmp_path: Path) -> None:
    code, report, _ = _doctor(tmp_path)
    checks = report["checks"]
    assert len(checks) >= 8
    assert all(set(c) == {"name", "level", "detail", "fix"} for c in checks)
    assert all(c["level"] in ("OK", "WARN", "ERROR") and c["detail"] for c in checks)
    assert all(c["fix"] for c in checks if c["level"] != "OK")  # every problem says what to do
    names = {c["name"] for c in checks}
    assert {
        "python",
        "packages",
        "rendering",
        "database",
        "disk",
        "audio",
        "serial port",
        "latency timer",
        "realtime",
        "cpu governor",
        "ports",
        "planner",
        "clock",
    } <= names
    assert code == (1 if any(c["level"] == "ERROR" for c in checks) else 0)
    by_name = {c["name"]: c for c in checks}
    assert by_name["database"]["level"] == "WARN" and "humanoid db upgrade" in by_name["database"]["fix"]


def test_doctor_exits_non_zero_for_the_real_robot_without_its_serial_device(tmp_path: Path) -> None:
    missing = str(tmp_path / "ttyUSB9")
    code, report, _ = _doctor(tmp_path, "--backend", "dynamixel", "--device", missing)
    serial = next(c for c in report["checks"] if c["name"] == "serial port")
    assert code == 1
    assert serial["level"] == "ERROR" and missing in serial["detail"]
    assert "/dev/serial/by-id" in serial["fix"]


def _as_nobody(check, machine_settings: Settings) -> dict:  # type: ignore[no-untyped-def]
    """Runs a check in a child process that has dropped root for `nobody` (no groups, no capabilities)."""
    reader, writer = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        try:
            os.setgroups([])
            os.setgid(grp.getgrnam("nogroup").gr_gid)
            os.setuid(65534)
            result = check(Machine(machine_settings)).to_json()
        except BaseException as exc:
            result = {"child failed": repr(exc)}
        finally:
            os.write(writer, json.dumps(result).encode())
            os._exit(0)
    os.close(writer)
    with os.fdopen(reader) as pipe:
        data = pipe.read()
    os.waitpid(pid, 0)
    return json.loads(data)


@pytest.mark.skipif(os.geteuid() != 0, reason="dropping to nobody needs root")
def test_a_serial_device_nobody_may_open_is_reported_with_the_group_to_join(tmp_path: Path, serial_device: str) -> None:
    # (pytest's temporary folders are closed to nobody: no robot.toml in one)
    settings = _settings(
        tmp_path, backend="dynamixel", dynamixel_port=serial_device, robot_config="/nowhere/robot.toml"
    )
    assert devices.check_serial(Machine(settings)).level == Level.OK  # root may
    found = _as_nobody(devices.check_serial, settings)
    assert found.get("level") == "ERROR", found
    assert "nobody may not read and write it" in found["detail"] and "group dialout" in found["detail"]
    assert found["fix"].startswith("sudo usermod -aG dialout nobody")


@pytest.mark.skipif(os.geteuid() != 0, reason="dropping to nobody needs root")
def test_real_time_scheduling_refused_is_a_warning_with_the_fix(tmp_path: Path) -> None:
    import resource

    if resource.getrlimit(resource.RLIMIT_RTPRIO)[0] != 0:
        pytest.skip("this machine lets every user have real-time priority")
    found = _as_nobody(system.check_realtime, _settings(tmp_path))
    assert found["level"] == "WARN" and "refused for nobody" in found["detail"]
    assert "service install" in found["fix"] and "rtprio" in found["fix"]


def test_an_injected_access_check_stands_for_another_user(tmp_path: Path, serial_device: str) -> None:
    settings = _settings(tmp_path, backend="sim", dynamixel_port=serial_device)
    denied = Machine(settings, access=lambda path, mode: path != serial_device, user=lambda: "operator")
    found = devices.check_serial(denied)
    assert found.level == Level.WARN  # configured, but the simulator is served: not an error yet
    assert found.fix.startswith("sudo usermod -aG dialout operator")


def _fake_sysfs(root: Path, device: str, latency_ms: str) -> None:
    name = Path(os.path.realpath(device)).name
    folder = root / "bus" / "usb-serial" / "devices" / name
    folder.mkdir(parents=True)
    (folder / "latency_timer").write_text(latency_ms + "\n")


def test_the_latency_timer_is_read_from_sysfs(tmp_path: Path, serial_device: str) -> None:
    settings = _settings(tmp_path, backend="dynamixel", dynamixel_port=serial_device)
    _fake_sysfs(tmp_path / "slow", serial_device, "16")
    slow = devices.check_latency_timer(Machine(settings, sys_root=tmp_path / "slow"))
    assert slow.level == Level.WARN and "16 ms" in slow.detail
    assert slow.fix.startswith("echo 1 | sudo tee ") and "service install" in slow.fix
    _fake_sysfs(tmp_path / "fast", serial_device, "1")
    assert devices.check_latency_timer(Machine(settings, sys_root=tmp_path / "fast")).level == Level.OK
    no_ftdi = devices.check_latency_timer(Machine(settings, sys_root=tmp_path / "none"))
    assert no_ftdi.level == Level.OK and "not an FTDI" in no_ftdi.detail


def test_the_cpu_governor_and_the_clock(tmp_path: Path) -> None:
    for cpu, governor in enumerate(["schedutil", "schedutil", "performance"]):
        folder = tmp_path / "devices" / "system" / "cpu" / f"cpu{cpu}" / "cpufreq"
        folder.mkdir(parents=True)
        (folder / "scaling_governor").write_text(governor + "\n")
    governor = system.check_cpu_governor(Machine(_settings(tmp_path), sys_root=tmp_path))
    assert governor.level == Level.WARN and "2 of 3 CPUs on schedutil" in governor.detail and governor.fix
    adrift = Machine(_settings(tmp_path), extras={"clock": lambda: (False, 16.0)})
    assert (
        system.check_clock(adrift).level == Level.WARN and "timedatectl set-ntp true" in system.check_clock(adrift).fix
    )
    synced = Machine(_settings(tmp_path), extras={"clock": lambda: (True, 0.0012)})
    assert system.check_clock(synced).level == Level.OK and "1.2 ms" in system.check_clock(synced).detail


def test_a_port_held_by_another_program_is_an_error_naming_it(tmp_path: Path) -> None:
    settings = _settings(tmp_path)
    with socket.socket() as holder:
        holder.bind((settings.host, settings.viser_port))
        holder.listen()
        found = services.check_ports(Machine(settings))
    assert found.level == Level.ERROR
    assert f"3D view: {settings.viser_port} is taken by pid {os.getpid()}" in found.detail
    assert "HUMANOID_VISER_PORT" in found.fix
    assert services.check_ports(Machine(settings)).level == Level.OK


class _FakeLLM(BaseHTTPRequestHandler):
    status = 200

    def do_GET(self) -> None:
        body = json.dumps({"data": [{"id": "qwen-2.5"}]}).encode()
        self.send_response(self.status)
        self.send_header("Content-Type", "application/json")
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args: object) -> None:
        pass


def test_the_planner_s_llm_server_when_one_is_configured(tmp_path: Path) -> None:
    server = ThreadingHTTPServer(("127.0.0.1", 0), _FakeLLM)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    base = f"http://127.0.0.1:{server.server_address[1]}/v1"
    try:
        settings = _settings(tmp_path, planner_backend="openai", openai_base_url=base, openai_model="qwen-2.5")
        assert services.check_planner(Machine(settings)).level == Level.OK
        other = services.check_planner(Machine(settings.model_copy(update={"openai_model": "gpt-9"})))
        assert other.level == Level.WARN and "qwen-2.5" in other.detail
        _FakeLLM.status = 401
        refused = services.check_planner(Machine(settings))
        assert refused.level == Level.WARN and "OPENAI_API_KEY" in refused.fix
    finally:
        _FakeLLM.status = 200
        server.shutdown()
        server.server_close()
    down = settings.model_copy(update={"openai_base_url": f"http://127.0.0.1:{free_port()}/v1"})
    assert services.check_planner(Machine(down)).level == Level.WARN  # plans fall back to the rules planner
    strict = services.check_planner(Machine(down.model_copy(update={"planner_fallback": False})))
    assert strict.level == Level.ERROR and "commands cannot be planned" in strict.detail
    rules = services.check_planner(Machine(_settings(tmp_path)))
    assert rules.level == Level.OK


def test_the_database_behind_or_ahead_of_the_code(tmp_path: Path) -> None:
    settings = _settings(tmp_path)
    upgrade_to_head(settings.database_url)
    assert services.check_database(Machine(settings)).level == Level.OK
    with sqlite3.connect(tmp_path / "humanoid.db") as db:
        db.execute("UPDATE alembic_version SET version_num = '0003'")
    behind = services.check_database(Machine(settings))
    assert behind.level == Level.WARN and "humanoid db upgrade --backup" in behind.fix
    with sqlite3.connect(tmp_path / "humanoid.db") as db:
        db.execute("UPDATE alembic_version SET version_num = '0099'")
    ahead = services.check_database(Machine(settings))
    assert ahead.level == Level.ERROR and "0099" in ahead.detail
    read_only = Machine(settings, access=lambda path, mode: False)
    assert services.check_database(read_only).level == Level.ERROR
    assert system.check_disk(read_only).level == Level.ERROR


def test_a_check_that_breaks_is_itself_reported_not_raised(tmp_path: Path) -> None:
    def broken(machine: Machine):  # type: ignore[no-untyped-def]
        raise PermissionError(13, "Permission denied", "/sys/bus/usb-serial")

    (found,) = run_checks([("latency timer", broken)], Machine(_settings(tmp_path)))
    assert found.level == Level.ERROR and "PermissionError" in found.detail and found.fix
