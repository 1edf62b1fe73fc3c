"""`humanoid doctor [--json]`: every check, in the order a bring-up meets them; exit code 1 when any is ERROR."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING

from app.settings import Settings

if TYPE_CHECKING:
    from app.deploy.doctor.report import CheckFunction


def all_checks() -> list[tuple[str, CheckFunction]]:
    """Imported when the doctor runs (httpx, psutil...), not at every start of the `humanoid` command."""
    from app.deploy.doctor import devices, services, system

    return [
        ("python", system.check_python),
        ("packages", system.check_packages),
        ("rendering", devices.check_rendering),
        ("database", services.check_database),
        ("disk", system.check_disk),
        ("audio", devices.check_audio),
        ("serial port", devices.check_serial),
        ("latency timer", devices.check_latency_timer),
        ("realtime", system.check_realtime),
        ("cpu governor", system.check_cpu_governor),
        ("ports", services.check_ports),
        ("planner", services.check_planner),
        ("clock", system.check_clock),
    ]


def _doctor(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.doctor.report import Machine, exit_code, render_text, run_checks

    overrides = {"backend": args.backend, "dynamixel_port": args.device}
    settings = settings.model_copy(update={k: v for k, v in overrides.items() if v is not None})
    checks = run_checks(all_checks(), Machine(settings))
    if args.json:
        print(json.dumps({"checks": [c.to_json() for c in checks]}, indent=2))
    else:
        print(render_text(checks))
    return exit_code(checks)


def add_doctor_parser(sub: argparse._SubParsersAction) -> None:
    doctor = sub.add_parser("doctor", help="check this computer for the robot and say what to fix")
    doctor.add_argument("--json", action="store_true", help='print {"checks": [{"name", "level", "detail", "fix"}]}')
    doctor.add_argument(
        "--backend",
        choices=["sim", "dynamixel"],
        default=None,
        help="check for this backend (default: HUMANOID_BACKEND, sim)",
    )
    doctor.add_argument("--device", default=None, help="the U2D2's serial device (default: robot.toml's)")
    doctor.set_defaults(func=_doctor)
