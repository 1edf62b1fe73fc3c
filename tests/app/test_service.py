"""`humanoid service unit | install | uninstall | status`: the unit systemd itself accepts, and installing it
into a target root (systemd is not PID 1 here, so nothing is started)."""

from __future__ import annotations

import os
import pwd
import shlex
import shutil
import stat
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import pytest

from app.cli.commands import build_parser
from app.deploy import service_cli
from app.deploy.install import Command, InstallError, apply, unreachable_paths
from app.deploy.unit import ServiceSpec, existing_groups
from app.settings import Settings

HUMANOID = Path(sys.executable).parent / "humanoid"


def _cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(HUMANOID), *args], capture_output=True, text=True, timeout=120, env={**os.environ, **(env or {})}
    )


def _parse(unit: str) -> dict[str, dict[str, list[str]]]:
    """A unit file's sections, each key with all its values (systemd allows a key more than once)."""
    sections: dict[str, dict[str, list[str]]] = defaultdict(lambda: defaultdict(list))
    section = ""
    for line in unit.splitlines():
        if line.startswith("[") and line.endswith("]"):
            section = line[1:-1]
        elif "=" in line and not line.startswith("#"):
            key, value = line.split("=", 1)
            sections[section][key].append(value)
    return sections


@pytest.fixture(scope="module")
def robot_unit() -> str:
    done = _cli(
        "service", "unit", "--backend", "dynamixel", "--device", "/dev/ttyUSB0", "--host", "0.0.0.0", "--port", "9000"
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("data_dir", ["/var/lib/humanoid", "/srv/robot data"])
def test_the_unit_passes_systemd_analyze_verify_without_a_warning(tmp_path: Path, data_dir: str) -> None:
    verify = shutil.which("systemd-analyze")
    assert verify, "systemd-analyze is missing: apt-get install systemd (make test does)"
    unit = _cli("service", "unit", "--backend", "dynamixel", "--device", "/dev/ttyUSB0", "--data-dir", data_dir)
    path = tmp_path / "humanoid.service"
    path.write_text(unit.stdout)
    done = subprocess.run([verify, "verify", str(path)], capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stderr) == (0, "")


def test_the_unit_serves_the_configured_robot_from_this_venv_as_a_dedicated_user(robot_unit: str) -> None:
    service = _parse(robot_unit)["Service"]
    (start,) = service["ExecStart"]
    words = shlex.split(start)
    assert words[0] == str(HUMANOID)
    args = build_parser().parse_args(words[1:])  # the very command `humanoid serve` accepts
    assert (args.command, args.host, args.http_port, args.backend, args.port) == (
        "serve",
        "0.0.0.0",
        9000,
        "dynamixel",
        "/dev/ttyUSB0",
    )
    assert service["User"] == ["humanoid"] and service["Group"] == ["humanoid"]
    assert "dialout" in service["SupplementaryGroups"][0].split()
    assert service["AmbientCapabilities"] == ["CAP_SYS_NICE"]
    assert service["Restart"] == ["on-failure"]
    assert service["KillMode"] == ["mixed"]  # SIGTERM to the server alone: it stops the robot process itself
    assert service["StandardOutput"] == ["journal"] and service["StandardError"] == ["journal"]
    assert service["StateDirectory"] == ["humanoid"]
    assert "DATABASE_URL=sqlite:////var/lib/humanoid/humanoid.db" in service["Environment"]
    assert "HUMANOID_AUDIO_DIR=/var/lib/humanoid/audio" in service["Environment"]
    (before,) = service["ExecStartPre"]
    args = build_parser().parse_args(shlex.split(before)[1:])
    assert (args.command, args.db_command, args.backup) == ("db", "upgrade", True)
    assert _parse(robot_unit)["Install"]["WantedBy"] == ["multi-user.target"]


def test_settings_from_the_environment_reach_the_unit() -> None:
    done = _cli("service", "unit", env={"HOST": "0.0.0.0", "PORT": "8123", "HUMANOID_BACKEND": "sim"})
    (start,) = _parse(done.stdout)["Service"]["ExecStart"]
    assert "--host 0.0.0.0 --http-port 8123 --backend sim" in start


def test_install_status_and_uninstall_in_a_target_root(tmp_path: Path) -> None:
    root = tmp_path / "root"
    root.mkdir()
    installed = _cli("service", "install", "--root", str(root))
    assert installed.returncode == 0, installed.stderr
    unit = root / "etc/systemd/system/humanoid.service"
    assert unit.read_text() == _cli("service", "unit").stdout
    assert (root / "etc/systemd/system/multi-user.target.wants/humanoid.service").is_symlink()  # enabled
    rule = (root / "etc/udev/rules.d/99-humanoid-u2d2-latency.rules").read_text()
    assert 'ATTR{latency_timer}="1"' in rule and 'DRIVER=="ftdi_sio"' in rule
    env_file = root / "etc/humanoid/humanoid.env"
    assert stat.S_IMODE(env_file.stat().st_mode) == 0o640  # secrets: not for everyone
    assert "skipped (not the running system): useradd" in installed.stdout  # users of the root are not touched

    status = _cli("service", "status", "--root", str(root), "--json")
    assert status.returncode == 0, status.stdout
    assert '"installed": true' in status.stdout and '"enabled": true' in status.stdout
    stale = _cli("service", "status", "--root", str(root), "--port", "9001")
    assert stale.returncode == 3 and "differs from `humanoid service unit`" in stale.stdout

    env_file.write_text("OPENAI_API_KEY=the operator's\n")
    _cli("service", "install", "--root", str(root))
    assert env_file.read_text() == "OPENAI_API_KEY=the operator's\n"  # never overwritten

    removed = _cli("service", "uninstall", "--root", str(root))
    assert removed.returncode == 0, removed.stderr
    assert not unit.exists() and not (root / "etc/systemd/system/multi-user.target.wants/humanoid.service").exists()
    assert env_file.exists() and "kept: the data in /var/lib/humanoid" in removed.stdout
    assert _cli("service", "status", "--root", str(root)).returncode == 3


def test_a_dry_run_says_what_it_would_do_and_changes_nothing() -> None:
    before = sorted(Path("/etc/systemd/system").glob("humanoid*"))
    done = _cli("service", "install", "--dry-run", "--user", "humanoid-test-nobody")
    assert done.returncode == 0, done.stderr
    assert "run useradd --system" in done.stdout and "humanoid-test-nobody" in done.stdout
    assert "write /etc/systemd/system/humanoid.service" in done.stdout
    assert "run systemctl enable humanoid.service\n  run systemctl restart humanoid.service" in done.stdout
    assert sorted(Path("/etc/systemd/system").glob("humanoid*")) == before
    with pytest.raises(KeyError):
        pwd.getpwnam("humanoid-test-nobody")


def test_install_on_the_running_system_needs_root(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    monkeypatch.setattr("app.deploy.install.is_root", lambda: False)
    args = build_parser().parse_args(["service", "install"])
    assert service_cli._install(args, Settings()) == 1
    assert "run it as root" in capsys.readouterr().err


def test_a_checkout_closed_to_other_users_is_named() -> None:
    base = Path(tempfile.mkdtemp(prefix="humanoid-service-"))
    try:
        base.chmod(0o755)
        home = base / "home"
        checkout = home / "humanoid"
        checkout.mkdir(parents=True)
        home.chmod(0o750)  # Ubuntu's home directories
        spec = ServiceSpec(executable=HUMANOID, working_dir=checkout, host="127.0.0.1", port=8000, backend="sim")
        assert any(f"{home} (mode 750)" in p and str(checkout) in p for p in unreachable_paths(spec))
        home.chmod(0o755)
        assert not any(str(checkout) in p for p in unreachable_paths(spec))
    finally:
        shutil.rmtree(base)


def test_a_failing_command_stops_the_install_with_what_it_said(tmp_path: Path) -> None:
    def refuse(argv: list[str]) -> subprocess.CompletedProcess:
        return subprocess.CompletedProcess(argv, 9, "", "useradd: group 'dialout' does not exist")

    with pytest.raises(InstallError, match="group 'dialout' does not exist"):
        apply([Command(("useradd", "humanoid"))], Path("/"), runner=refuse)


def test_only_groups_that_exist_are_named(tmp_path: Path) -> None:
    group_file = tmp_path / "group"
    group_file.write_text("root:x:0:\ndialout:x:20:\naudio:x:29:\n")
    assert existing_groups(group_file=group_file) == ("dialout", "audio")


NOT_ABOUT_THE_PROCESS = {
    "Type",
    "ExecStartPre",
    "ExecStart",
    "KillMode",
    "KillSignal",
    "TimeoutStopSec",
    "Restart",
    "RestartSec",
    "RestartPreventExitStatus",
    "StandardOutput",
    "StandardError",
    "SyslogIdentifier",
}


def test_the_service_doctor_runs_the_doctor_as_the_unit_runs_the_server(robot_unit: str) -> None:
    """Same user, groups, capability, sandbox and environment: what the service may open is what is checked."""
    done = _cli(
        "service",
        "doctor",
        "--dry-run",
        "--backend",
        "dynamixel",
        "--device",
        "/dev/ttyUSB0",
        "--host",
        "0.0.0.0",
        "--port",
        "9000",
    )
    words = shlex.split(done.stdout)
    assert words[0] == "systemd-run" and {"--wait", "--pipe"} <= set(words)
    properties = [w.removeprefix("--property=") for w in words if w.startswith("--property=")]
    expected = [
        f"{key}={value}"
        for key, values in _parse(robot_unit)["Service"].items()
        for value in values
        if key not in NOT_ABOUT_THE_PROCESS
    ]
    assert properties == expected
    assert words[-6:] == [str(HUMANOID), "doctor", "--backend", "dynamixel", "--device", "/dev/ttyUSB0"]


def test_service_run_gives_the_cli_the_service_s_own_database() -> None:
    done = _cli("service", "run", "--dry-run", "users", "add", "ada", "--role", "operator")
    words = shlex.split(done.stdout)
    assert "--property=Environment=DATABASE_URL=sqlite:////var/lib/humanoid/humanoid.db" in words
    assert "--property=StateDirectory=humanoid" in words  # made before the first start, owned by the service
    assert words[-6:] == [str(HUMANOID), "users", "add", "ada", "--role", "operator"]
    assert _cli("service", "run", "--dry-run").returncode == 2  # nothing to run
