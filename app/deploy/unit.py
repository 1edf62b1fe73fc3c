"""The systemd system unit that runs `humanoid serve` at boot, and the files that go with it (a udev rule for the
U2D2's latency timer, an environment file for secrets). Text only: installing is app/deploy/install.py's job.

A system unit, not a `--user` one: only a system unit may grant a non-root user CAP_SYS_NICE (ambient
capabilities), which the control thread needs for real-time scheduling. `systemctl stop` sends SIGTERM to the
server alone (KillMode=mixed): uvicorn then ends the app, whose shutdown stops the robot process the controlled
way (on the real robot: crouch, then torque off). With systemd's default, every process of the service would get
SIGTERM at once and the robot process would die before it could stop the robot.
"""

from __future__ import annotations

import grp
import sys
from dataclasses import dataclass, field
from pathlib import Path

from app.settings import REPO_ROOT, Settings

SERVICE_NAME = "humanoid"
DEFAULT_DATA_DIR = Path("/var/lib/humanoid")
ENV_FILE = Path("/etc/humanoid/humanoid.env")
UDEV_RULE = Path("/etc/udev/rules.d/99-humanoid-u2d2-latency.rules")
# dialout: the U2D2's serial device; audio: microphone and speaker (ALSA: a system service has no PulseAudio);
# video, render: the GPU for EGL (a Jetson's /dev/nvhost-*, a PC's /dev/dri)
WANTED_GROUPS = ("dialout", "audio", "video", "render")
STOP_TIMEOUT_S = 30  # the controlled stop takes a few seconds; then systemd kills what is left
KEEP_BACKUPS = 5
CONFIG_ERROR_EXIT = 2  # `humanoid serve`'s exit code for a refused configuration: restarting cannot help


@dataclass(frozen=True)
class ServiceSpec:
    """Everything the unit says: what runs, as whom, serving what, and where its data goes."""

    executable: Path  # the venv's `humanoid`
    working_dir: Path  # the checkout: its .env is read as by `make run`
    host: str
    port: int
    backend: str
    device: str = ""  # the U2D2's serial device, when set on the command line or HUMANOID_DYNAMIXEL_PORT
    robot_config: str = ""
    data_dir: Path = DEFAULT_DATA_DIR
    user: str = SERVICE_NAME
    groups: tuple[str, ...] = field(default_factory=tuple)
    name: str = SERVICE_NAME

    @property
    def unit_name(self) -> str:
        return f"{self.name}.service"

    @property
    def database_url(self) -> str:
        return f"sqlite:///{self.data_dir / 'humanoid.db'}"

    @property
    def managed_data_dir(self) -> str | None:
        """The StateDirectory= name when the data lives under /var/lib (systemd creates and owns it)."""
        if self.data_dir.parent == Path("/var/lib"):
            return self.data_dir.name
        return None


def existing_groups(names: tuple[str, ...] = WANTED_GROUPS, group_file: Path | None = None) -> tuple[str, ...]:
    """Those of `names` that exist (a unit naming a missing group fails to start)."""
    if group_file is not None:
        known = {line.split(":", 1)[0] for line in group_file.read_text().splitlines() if ":" in line}
        return tuple(n for n in names if n in known)
    found = []
    for name in names:
        try:
            grp.getgrnam(name)
            found.append(name)
        except KeyError:
            pass
    return tuple(found)


def spec_from_settings(
    settings: Settings,
    *,
    data_dir: Path = DEFAULT_DATA_DIR,
    user: str = SERVICE_NAME,
    groups: tuple[str, ...] | None = None,
) -> ServiceSpec:
    """The unit for these settings (environment, .env, and the command line's overrides), run from this venv."""
    return ServiceSpec(
        executable=Path(sys.executable).parent / "humanoid",
        working_dir=REPO_ROOT,
        host=settings.host,
        port=settings.port,
        backend=settings.backend,
        device=settings.dynamixel_port,
        robot_config=settings.robot_config,
        data_dir=data_dir,
        user=user,
        groups=existing_groups() if groups is None else groups,
    )


def is_sqlite(url: str) -> bool:
    from sqlalchemy.engine import make_url  # here: the `humanoid` command starts without sqlalchemy

    return make_url(url).get_backend_name() == "sqlite"


def _escape(value: str) -> str:
    """One word of a unit file: `%` is systemd's specifier character; spaces and quotes need quoting."""
    value = value.replace("%", "%%")
    if any(c in value for c in " \t\"'\\;"):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return value


def _command(*words: str) -> str:
    return " ".join(_escape(w) for w in words)


def serve_command(spec: ServiceSpec) -> list[str]:
    command = [
        str(spec.executable),
        "serve",
        "--host",
        spec.host,
        "--http-port",
        str(spec.port),
        "--backend",
        spec.backend,
    ]
    if spec.backend == "dynamixel" and spec.device:
        command += ["--port", spec.device]
    return command


def environment(spec: ServiceSpec) -> dict[str, str]:
    """The service's own settings (the environment outranks the checkout's .env; ENV_FILE outranks these)."""
    env = {
        "DATABASE_URL": spec.database_url,
        "HUMANOID_AUDIO_DIR": str(spec.data_dir / "audio"),
        "PYTHONUNBUFFERED": "1",  # each line reaches the journal as it is printed
    }
    if spec.robot_config:
        env["HUMANOID_ROBOT_CONFIG"] = spec.robot_config
    return env


def process_properties(spec: ServiceSpec) -> list[tuple[str, str]]:
    """The settings that make the service's process what it is (who, with which groups and capability, where,
    with which environment): the unit's, and `humanoid service doctor`'s (systemd-run with the same)."""
    properties = [("User", spec.user), ("Group", spec.user)]
    if spec.groups:
        properties.append(("SupplementaryGroups", " ".join(spec.groups)))
    properties += [
        ("AmbientCapabilities", "CAP_SYS_NICE"),  # real-time scheduling for the control thread, without root
        ("CapabilityBoundingSet", "CAP_SYS_NICE"),
        ("NoNewPrivileges", "yes"),
        ("ProtectSystem", "full"),
        ("PrivateTmp", "yes"),
        ("ProtectKernelModules", "yes"),
        ("ProtectControlGroups", "yes"),
        ("UMask", "0027"),
    ]
    if spec.managed_data_dir:
        properties += [("StateDirectory", spec.managed_data_dir), ("StateDirectoryMode", "0750")]
    else:
        properties.append(("ReadWritePaths", _escape(str(spec.data_dir))))
    properties.append(("WorkingDirectory", _escape(str(spec.working_dir))))
    properties += [("Environment", _escape(f"{k}={v}")) for k, v in environment(spec).items()]
    properties.append(("EnvironmentFile", f"-{_escape(str(ENV_FILE))}"))
    return properties


def render_unit(spec: ServiceSpec) -> str:
    docs = (spec.working_dir / "docs" / "robot-computer.md").as_uri()
    lines = [
        f"# {spec.unit_name}: Humanoid mission control, written by `humanoid service unit`.",
        "# Local changes that survive a new install: `systemctl edit humanoid` (a drop-in); secrets such as",
        f"# OPENAI_API_KEY or a PostgreSQL DATABASE_URL: {ENV_FILE}.",
        "[Unit]",
        "Description=Humanoid mission control (humanoid serve)",
        f"Documentation={_escape(docs)}",
        "After=network-online.target sound.target time-sync.target",
        "Wants=network-online.target",
        "StartLimitIntervalSec=300",
        "StartLimitBurst=5",
        "",
        "[Service]",
        "Type=exec",
        *(f"{key}={value}" for key, value in process_properties(spec)),
        "# migrations after a backup of the SQLite file (the last few are kept)",
        f"ExecStartPre={_command(str(spec.executable), 'db', 'upgrade', '--backup', '--keep', str(KEEP_BACKUPS))}",
        f"ExecStart={_command(*serve_command(spec))}",
        "# SIGTERM to the server only: its shutdown stops the robot the controlled way, then systemd ends the rest",
        "KillMode=mixed",
        "KillSignal=SIGTERM",
        f"TimeoutStopSec={STOP_TIMEOUT_S}",
        "Restart=on-failure",
        "RestartSec=5",
        f"RestartPreventExitStatus={CONFIG_ERROR_EXIT}",
        "StandardOutput=journal",
        "StandardError=journal",
        f"SyslogIdentifier={spec.name}",
        "",
        "[Install]",
        "WantedBy=multi-user.target",
    ]
    return "\n".join(lines) + "\n"


def as_service_command(spec: ServiceSpec, humanoid_args: list[str], terminal: bool = False) -> list[str]:
    """`humanoid ARGS` run as the service runs (its user, groups, capability, sandbox and environment), by
    systemd-run: on the service's own database (users, sessions, backups), and for `doctor`, what the service
    itself may open, which differs from what the operator's login may. `terminal`: a tty for prompts."""
    command = ["systemd-run", "--quiet", "--wait", "--collect", "--pty" if terminal else "--pipe"]
    command += [f"--property={key}={value}" for key, value in process_properties(spec)]
    return [*command, str(spec.executable), *humanoid_args]


def doctor_arguments(spec: ServiceSpec) -> list[str]:
    return ["doctor", "--backend", spec.backend, *(["--device", spec.device] if spec.device else [])]


def render_udev_rule() -> str:
    """Every FTDI adapter (the U2D2 is one) at a 1 ms latency timer as it is plugged in: with the default 16 ms
    each missing reply costs 34 ms."""
    return (
        "# Written by `humanoid service install`: the U2D2's (FTDI) USB latency timer at 1 ms.\n"
        'ACTION=="add", SUBSYSTEM=="usb-serial", DRIVER=="ftdi_sio", ATTR{latency_timer}="1"\n'
    )


def render_env_file(settings: Settings) -> str:
    """Kept when it exists (the operator's edits). A configured PostgreSQL URL goes here, not into the unit,
    whose text anyone may read (`systemctl show`)."""
    lines = [
        "# Settings of the humanoid service that are not for everyone's eyes (this file: root and the service",
        "# user only). They outrank the unit's Environment= lines. Apply with: systemctl restart humanoid",
        "# OPENAI_API_KEY=...",
    ]
    if is_sqlite(settings.database_url):
        lines.append("# DATABASE_URL=postgresql+psycopg://user:password@host/humanoid")
    else:
        lines.append(f"DATABASE_URL={settings.database_url}")
    return "\n".join(lines) + "\n"
