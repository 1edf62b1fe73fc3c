"""Installs, removes and reports the humanoid service: a plan of file writes and commands, then carried out (or
only shown with --dry-run). Under a target root other than / (a system image, the tests: systemd is not PID 1
there) files go under that root and only commands that work offline run (`systemctl --root=DIR enable`)."""

from __future__ import annotations

import os
import pwd
import shlex
import shutil
import stat
import subprocess
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from app.deploy.unit import ENV_FILE, UDEV_RULE, ServiceSpec, existing_groups, render_udev_rule, render_unit

UNIT_DIR = Path("/etc/systemd/system")
Runner = Callable[[list[str]], subprocess.CompletedProcess]


def run_command(argv: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(argv, capture_output=True, text=True, timeout=120)


@dataclass(frozen=True)
class WriteFile:
    path: Path  # as on the running system; placed under the target root
    content: str
    mode: int = 0o644
    group: str | None = None  # owned by root:group when that group exists
    keep_existing: bool = False  # the operator's file: never overwritten


@dataclass(frozen=True)
class RemoveFile:
    path: Path


@dataclass(frozen=True)
class Command:
    argv: tuple[str, ...]
    offline: bool = False  # works on a target root too (systemctl --root)
    optional: bool = False  # the tool may be missing (udevadm in a container): skipped, not a failure


Action = WriteFile | RemoveFile | Command


class InstallError(RuntimeError):
    """Said to the operator plainly: what failed, and what to do."""


def unit_path(spec: ServiceSpec) -> Path:
    return UNIT_DIR / spec.unit_name


def _user_exists(name: str, root: Path) -> bool:
    if root == Path("/"):
        try:
            pwd.getpwnam(name)
            return True
        except KeyError:
            return False
    passwd = root / "etc" / "passwd"
    return passwd.exists() and any(line.split(":", 1)[0] == name for line in passwd.read_text().splitlines())


def plan_install(spec: ServiceSpec, env_file: str, root: Path = Path("/")) -> list[Action]:
    actions: list[Action] = []
    if not _user_exists(spec.user, root):
        add_user = [
            "useradd",
            "--system",
            "--user-group",
            "--home-dir",
            str(spec.data_dir),
            "--no-create-home",
            "--shell",
            "/usr/sbin/nologin",
            "--comment",
            "humanoid mission control",
        ]
        if spec.groups:
            add_user += ["--groups", ",".join(spec.groups)]
        actions.append(Command((*add_user, spec.user)))
    elif spec.groups:
        actions.append(Command(("usermod", "--append", "--groups", ",".join(spec.groups), spec.user)))
    if not spec.managed_data_dir:  # systemd makes a StateDirectory itself
        actions.append(Command(("install", "-d", "-m", "0750", "-o", spec.user, "-g", spec.user, str(spec.data_dir))))
    actions += [
        WriteFile(unit_path(spec), render_unit(spec)),
        WriteFile(ENV_FILE, env_file, mode=0o640, group=spec.user, keep_existing=True),
        WriteFile(UDEV_RULE, render_udev_rule()),
        Command(("udevadm", "control", "--reload"), optional=True),
        Command(("udevadm", "trigger", "--action=add", "--subsystem-match=usb-serial"), optional=True),
        Command(("systemctl", "daemon-reload")),
    ]
    if root != Path("/"):
        return [*actions, Command(("systemctl", f"--root={root}", "enable", spec.unit_name), offline=True)]
    # restart, not start: installed again over a running service, the new unit applies now (its stop is the
    # controlled one)
    return [
        *actions,
        Command(("systemctl", "enable", spec.unit_name)),
        Command(("systemctl", "restart", spec.unit_name)),
    ]


def plan_uninstall(spec: ServiceSpec, root: Path = Path("/")) -> list[Action]:
    """The unit and the udev rule go; the data, the environment file and the user stay (said afterwards)."""
    disable = (
        Command(("systemctl", f"--root={root}", "disable", spec.unit_name), offline=True)
        if root != Path("/")
        else Command(("systemctl", "disable", "--now", spec.unit_name))
    )
    return [
        disable,
        RemoveFile(unit_path(spec)),
        RemoveFile(UDEV_RULE),
        Command(("systemctl", "daemon-reload")),
        Command(("udevadm", "control", "--reload"), optional=True),
    ]


def describe(action: Action) -> str:
    if isinstance(action, WriteFile):
        kept = " (kept if it exists)" if action.keep_existing else ""
        return f"write {action.path} (mode {action.mode:o}){kept}"
    if isinstance(action, RemoveFile):
        return f"remove {action.path}"
    return "run " + shlex.join(action.argv)


def _under(root: Path, path: Path) -> Path:
    return root / path.relative_to("/")


def apply(actions: list[Action], root: Path = Path("/"), runner: Runner = run_command) -> list[str]:
    """Carries the plan out in order; returns a line per action. A failing command stops it (InstallError)."""
    live = root == Path("/")
    done: list[str] = []
    for action in actions:
        if isinstance(action, WriteFile):
            target = _under(root, action.path)
            if action.keep_existing and target.exists():
                done.append(f"kept {target} (exists)")
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(action.content)
            target.chmod(action.mode)
            if action.group and live and existing_groups((action.group,)):
                shutil.chown(target, group=action.group)
            done.append(f"wrote {target}")
        elif isinstance(action, RemoveFile):
            target = _under(root, action.path)
            if target.exists():
                target.unlink()
                done.append(f"removed {target}")
            else:
                done.append(f"{target} was not there")
        elif not live and not action.offline:
            done.append(f"skipped (not the running system): {shlex.join(action.argv)}")
        elif action.optional and shutil.which(action.argv[0]) is None:
            done.append(f"skipped ({action.argv[0]} is not installed): {shlex.join(action.argv)}")
        else:
            result = runner(list(action.argv))
            if result.returncode != 0:
                said = (result.stderr or result.stdout).strip()
                raise InstallError(f"{shlex.join(action.argv)} failed ({result.returncode}): {said}")
            done.append(f"ran {shlex.join(action.argv)}")
    return done


def unreachable_paths(spec: ServiceSpec) -> list[str]:
    """What another user (the service's) cannot reach: a folder on the way to the checkout or to the venv's
    Python without others' execute permission (a home directory of mode 750, pyenv under /root)."""
    problems = []
    for target in (spec.working_dir.resolve(), (spec.executable.parent / "python").resolve()):
        folders = [*reversed(target.parents), *([target] if target.is_dir() else [])]
        for folder in folders:
            mode = folder.stat().st_mode
            if not mode & stat.S_IXOTH:
                problems.append(
                    f"{folder} (mode {stat.S_IMODE(mode):o}) is closed to other users, so the service "
                    f"user cannot reach {target}"
                )
                break
    return problems


@dataclass(frozen=True)
class ServiceStatus:
    installed: bool
    current: bool  # the installed unit is the one these settings make
    enabled: bool
    user_exists: bool
    udev_rule: bool
    active: str  # systemctl is-active, or why it is not known

    @property
    def ok(self) -> bool:
        return (
            self.installed
            and self.current
            and self.enabled
            and (self.active == "active" or self.active.startswith("unknown"))
        )

    def lines(self, spec: ServiceSpec) -> list[str]:
        return [
            f"unit {unit_path(spec)}: "
            + ("installed" if self.installed else "not installed")
            + ("" if not self.installed or self.current else " (differs from `humanoid service unit`: install again)"),
            f"enabled at boot: {'yes' if self.enabled else 'no'}",
            f"service user {spec.user}: {'exists' if self.user_exists else 'missing'}",
            f"udev rule {UDEV_RULE}: {'installed' if self.udev_rule else 'missing'}",
            f"state: {self.active}",
        ]


def service_status(spec: ServiceSpec, root: Path = Path("/"), runner: Runner = run_command) -> ServiceStatus:
    unit = _under(root, unit_path(spec))
    wants = _under(root, UNIT_DIR / "multi-user.target.wants" / spec.unit_name)
    if root != Path("/") or not Path("/run/systemd/system").exists():
        active = "unknown (systemd is not running here)"
    else:
        active = runner(["systemctl", "is-active", spec.unit_name]).stdout.strip() or "unknown"
    return ServiceStatus(
        installed=unit.exists(),
        current=unit.exists() and unit.read_text() == render_unit(spec),
        enabled=wants.is_symlink() or wants.exists(),
        user_exists=_user_exists(spec.user, root),
        udev_rule=_under(root, UDEV_RULE).exists(),
        active=active,
    )


def is_root() -> bool:
    return os.geteuid() == 0
