"""What a check finds (a level, a detail, a one-line fix), the machine the checks look at, and running them so
that a check that breaks is itself reported, with what to do, never as a traceback."""

from __future__ import annotations

import contextlib
import grp
import os
import pwd
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from pathlib import Path

from app.settings import Settings


class Level(StrEnum):
    OK = "OK"
    WARN = "WARN"
    ERROR = "ERROR"


@dataclass(frozen=True)
class Check:
    name: str
    level: Level
    detail: str
    fix: str = ""  # one line; empty when there is nothing to fix

    def to_json(self) -> dict[str, str]:
        return {**asdict(self), "level": str(self.level)}


def ok(name: str, detail: str) -> Check:
    return Check(name, Level.OK, detail)


def _process_groups() -> set[str]:
    names = set()
    for gid in {os.getegid(), *os.getgroups()}:
        with contextlib.suppress(KeyError):
            names.add(grp.getgrgid(gid).gr_name)
    return names


def _user_name() -> str:
    """Who this process runs as (not $USER, which sudo and su may leave as it was)."""
    try:
        return pwd.getpwuid(os.geteuid()).pw_name
    except KeyError:
        return str(os.geteuid())


@dataclass
class Machine:
    """What the checks look at. Tests replace parts: as root every permission check passes, so `access` stands
    in for the kernel's answer to another user."""

    settings: Settings
    access: Callable[[str, int], bool] = os.access
    user: Callable[[], str] = _user_name
    groups: Callable[[], set[str]] = _process_groups
    sys_root: Path = Path("/sys")
    timeout_s: float = 3.0
    extras: dict = field(default_factory=dict)  # per-check stand-ins (e.g. "realtime", "clock")


CheckFunction = Callable[[Machine], Check]


def run_checks(checks: list[tuple[str, CheckFunction]], machine: Machine) -> list[Check]:
    results = []
    for name, check in checks:
        try:
            results.append(check(machine))
        except Exception as exc:  # a check's own failure is a finding too, never a traceback
            results.append(
                Check(
                    name,
                    Level.ERROR,
                    f"the check itself failed: {type(exc).__name__}: {exc}",
                    "run `humanoid doctor` again; if it fails the same way, report it with this line",
                )
            )
    return results


def exit_code(checks: list[Check]) -> int:
    return 1 if any(c.level == Level.ERROR for c in checks) else 0


def render_text(checks: list[Check]) -> str:
    width = max(len(c.name) for c in checks)
    lines = []
    for c in checks:
        lines.append(f"{c.level:<5}  {c.name:<{width}}  {c.detail}")
        if c.fix:
            lines.append(f"{'':<5}  {'':<{width}}  fix: {c.fix}")
    counts = {level: sum(c.level == level for c in checks) for level in Level}
    lines.append(f"{len(checks)} checks: " + ", ".join(f"{n} {level}" for level, n in counts.items()))
    return "\n".join(lines)
