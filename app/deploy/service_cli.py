"""`humanoid service unit | install | uninstall | status | doctor | run`: the console as a systemd service on the
robot's computer (starts at boot, restarts on failure, real-time priority without root, logs in the journal)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from app.deploy.unit import DEFAULT_DATA_DIR, SERVICE_NAME, ServiceSpec, spec_from_settings
from app.settings import Settings

if TYPE_CHECKING:
    from app.deploy.install import Action


def _spec(args: argparse.Namespace, settings: Settings) -> tuple[ServiceSpec, Settings]:
    overrides = {"host": args.host, "port": args.port, "backend": args.backend, "dynamixel_port": args.device}
    settings = settings.model_copy(update={k: v for k, v in overrides.items() if v is not None})
    return spec_from_settings(settings, data_dir=Path(args.data_dir), user=args.user), settings


def _unit(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.unit import render_unit

    spec, _ = _spec(args, settings)
    print(render_unit(spec), end="")
    return 0


def _refuse_unless_root(args: argparse.Namespace) -> bool:
    from app.deploy.install import is_root

    if args.dry_run or Path(args.root) != Path("/") or is_root():
        return False
    print(
        f"humanoid service {args.service_command} changes the system: run it as root "
        f"(sudo {sys.argv[0]} service {args.service_command} ...), or add --dry-run to see what it would do",
        file=sys.stderr,
    )
    return True


def _show(actions: list, root: Path) -> None:
    from app.deploy.install import describe

    where = "" if root == Path("/") else f" under {root}"
    print(f"would do{where}:")
    for action in actions:
        print(f"  {describe(action)}")


def _install(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.install import plan_install, unreachable_paths
    from app.deploy.unit import render_env_file

    if _refuse_unless_root(args):
        return 1
    spec, settings = _spec(args, settings)
    root = Path(args.root)
    problems = unreachable_paths(spec)
    for problem in problems:
        print(f"warning: {problem}", file=sys.stderr)
    if problems:
        print(
            "  fix: put the checkout where every user can read it (e.g. /opt/humanoid) and make its .venv with a "
            "Python every user can run (the system's, deadsnakes', or uv's installed with "
            "UV_PYTHON_INSTALL_DIR=/opt/uv-python), then install again",
            file=sys.stderr,
        )
        if root == Path("/") and not args.dry_run:
            return 1
    actions = plan_install(spec, render_env_file(settings), root)
    if args.dry_run:
        _show(actions, root)
        return 0
    if not _apply(actions, root, "install"):
        return 1
    print(
        f"installed {spec.unit_name}: `journalctl -u {spec.name} -f` shows its log, "
        f"`humanoid service status` its state, `humanoid doctor` what to fix on this machine"
    )
    return 0


def _apply(actions: list[Action], root: Path, verb: str) -> bool:
    """Carry out a plan of file actions, printing each; False (said on stderr) if one failed."""
    from app.deploy.install import InstallError, apply

    try:
        for line in apply(actions, root):
            print(line)
    except InstallError as exc:
        print(f"humanoid service {verb}: {exc}", file=sys.stderr)
        return False
    return True


def _uninstall(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.install import plan_uninstall
    from app.deploy.unit import ENV_FILE

    if _refuse_unless_root(args):
        return 1
    spec, _ = _spec(args, settings)
    root = Path(args.root)
    actions = plan_uninstall(spec, root)
    if args.dry_run:
        _show(actions, root)
        return 0
    if not _apply(actions, root, "uninstall"):
        return 1
    print(
        f"kept: the data in {spec.data_dir}, {ENV_FILE} and the user {spec.user} (to remove them too: "
        f"userdel {spec.user}; rm -r {spec.data_dir} {ENV_FILE.parent})"
    )
    return 0


def _status(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.install import service_status

    spec, _ = _spec(args, settings)
    status = service_status(spec, Path(args.root))
    if args.json:
        print(json.dumps({**dataclasses.asdict(status), "ok": status.ok}, indent=2))
    else:
        print("\n".join(status.lines(spec)))
    return 0 if status.ok else 3  # 3: as `systemctl status` says of a unit that is not running


def _as_service(args: argparse.Namespace, settings: Settings) -> int:
    """`humanoid ...` as the service runs it (systemd-run): `service doctor`, and `service run ARGS`."""
    import shlex
    import subprocess

    from app.deploy.install import is_root
    from app.deploy.unit import as_service_command, doctor_arguments

    spec, _ = _spec(args, settings)
    humanoid_args = doctor_arguments(spec) if args.service_command == "doctor" else args.humanoid_args
    if not humanoid_args:
        print("say what to run, e.g.: humanoid service run users add ada --role operator", file=sys.stderr)
        return 2
    command = as_service_command(spec, humanoid_args, terminal=sys.stdin.isatty())
    if args.dry_run:
        print(shlex.join(command))
        return 0
    if not Path("/run/systemd/system").exists():
        print(
            "systemd is not running here: run this on the robot's computer (--dry-run shows the command)",
            file=sys.stderr,
        )
        return 1
    if not is_root():
        print(f"run it as root: sudo {sys.argv[0]} service {args.service_command} ...", file=sys.stderr)
        return 1
    return subprocess.run(command).returncode


def add_service_parser(sub: argparse._SubParsersAction) -> None:
    service = sub.add_parser("service", help="run the console as a systemd service (the robot's computer)")
    commands = service.add_subparsers(dest="service_command", required=True)
    for name, func, help_text in (
        ("unit", _unit, "print the systemd unit"),
        ("install", _install, "install, enable and start the service (root)"),
        ("uninstall", _uninstall, "stop, disable and remove it; the data stays (root)"),
        ("status", _status, "is it installed, current, enabled, running"),
        ("doctor", _as_service, "run `humanoid doctor` as the service runs (its user, groups, capability; root)"),
        ("run", _as_service, "run `humanoid ARGS` as the service, on its data: users add, sessions list... (root)"),
    ):
        command = commands.add_parser(name, help=help_text)
        command.add_argument("--host", default=None, help="interface to serve on (default: HOST, 127.0.0.1)")
        command.add_argument("--port", type=int, default=None, help="HTTP port (default: PORT, 8000)")
        command.add_argument(
            "--backend",
            choices=["sim", "dynamixel"],
            default=None,
            help="sim or dynamixel (default: HUMANOID_BACKEND, sim)",
        )
        command.add_argument("--device", default=None, help="the U2D2's serial device (default: robot.toml's)")
        command.add_argument(
            "--data-dir",
            default=str(DEFAULT_DATA_DIR),
            help=f"the service's database, recordings and backups (default {DEFAULT_DATA_DIR})",
        )
        command.add_argument("--user", default=SERVICE_NAME, help=f"the service user (default {SERVICE_NAME})")
        if name in ("install", "uninstall", "status"):
            command.add_argument("--root", default="/", help="target root directory (an image, tests)")
        if name == "run":
            command.add_argument(
                "humanoid_args",
                nargs=argparse.REMAINDER,
                metavar="ARGS",
                help="a humanoid command and its arguments, e.g. users add ada --role operator",
            )
        if name in ("install", "uninstall", "doctor", "run"):
            command.add_argument("--dry-run", action="store_true", help="print what would be done, do nothing")
        if name == "status":
            command.add_argument("--json", action="store_true")
        command.set_defaults(func=func)
