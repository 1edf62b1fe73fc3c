"""Checks of the computer itself: Python and the installed packages, real-time scheduling, the CPU governor, the
clock, and disk space for sessions."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import resource
import shutil
import sys
import threading
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet

from app.deploy.doctor.report import Check, Level, Machine, ok

DISTRIBUTION = "humanoid-mission-control"
CAP_SYS_NICE = 23
MIN_FREE_BYTES = 2e9  # below this a few long sessions with camera frames fill the disk
SHOWN_PACKAGES = ("mujoco", "placo", "fastapi", "uvicorn", "sqlalchemy", "pocketsphinx", "dynamixel-sdk")


def check_python(machine: Machine) -> Check:
    wanted = SpecifierSet(metadata.metadata(DISTRIBUTION)["Requires-Python"] or "")
    version = ".".join(str(n) for n in sys.version_info[:3])
    if version in wanted:
        return ok("python", f"Python {version} ({sys.executable})")
    return Check(
        "python",
        Level.ERROR,
        f"Python {version} ({sys.executable}); this project needs {wanted}",
        "make the venv again with a supported Python: rm -rf .venv && make run (it finds or names one)",
    )


def check_packages(machine: Machine) -> Check:
    """Every runtime requirement of the installed package, installed at a version it accepts."""
    problems = []
    found = {}
    for text in metadata.requires(DISTRIBUTION) or []:
        requirement = Requirement(text)
        if requirement.marker is not None and not requirement.marker.evaluate({"extra": ""}):
            continue  # an optional extra's
        try:
            installed = metadata.version(requirement.name)
        except metadata.PackageNotFoundError:
            problems.append(f"{requirement.name} is missing")
            continue
        found[requirement.name] = installed
        if not requirement.specifier.contains(installed, prereleases=True):
            problems.append(f"{requirement.name} {installed} (wanted {requirement.specifier})")
    if problems:
        return Check(
            "packages",
            Level.ERROR,
            "; ".join(problems),
            "install what pyproject.toml asks for: make run (or .venv/bin/pip install -e .)",
        )
    shown = ", ".join(f"{name} {found[name]}" for name in SHOWN_PACKAGES if name in found)
    return ok("packages", f"{len(found)} dependencies as pyproject.toml asks ({shown}, ...)")


def _has_cap_sys_nice() -> bool:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("CapEff:"):
            return bool(int(line.split()[1], 16) >> CAP_SYS_NICE & 1)
    return False


def try_realtime(priority: int) -> str:
    """Asks for SCHED_FIFO on a throwaway thread (the control loop's request); "" when granted, else why not."""
    outcome: list[str] = []

    def attempt() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))  # this thread only
            outcome.append("")
        except (OSError, AttributeError) as exc:
            outcome.append(str(exc))

    thread = threading.Thread(target=attempt, name="doctor-realtime")
    thread.start()
    thread.join()
    return outcome[0]


def check_realtime(machine: Machine) -> Check:
    from robot.control.priority import CONTROL_FIFO_PRIORITY

    refusal = machine.extras.get("realtime", try_realtime)(CONTROL_FIFO_PRIORITY)
    soft, _ = resource.getrlimit(resource.RLIMIT_RTPRIO)
    grounds = [g for g, held in (("root", os.geteuid() == 0), ("CAP_SYS_NICE", _has_cap_sys_nice())) if held]
    limit = "unlimited" if soft == resource.RLIM_INFINITY else str(soft)
    if not refusal:
        why = " and ".join(grounds) or f"RLIMIT_RTPRIO {limit}"
        return ok("realtime", f"the control thread may run at SCHED_FIFO {CONTROL_FIFO_PRIORITY} ({why})")
    return Check(
        "realtime",
        Level.WARN,
        f"SCHED_FIFO {CONTROL_FIFO_PRIORITY} refused for {machine.user()} ({refusal}; RLIMIT_RTPRIO {limit}): "
        "the control loop would run at normal priority and miss ticks on a busy computer",
        "run it as the service (sudo .venv/bin/humanoid service install: CAP_SYS_NICE), or allow this user: "
        f"echo '{machine.user()} - rtprio 95' | sudo tee /etc/security/limits.d/humanoid.conf, then log in "
        "again",
    )


def check_cpu_governor(machine: Machine) -> Check:
    files = sorted((machine.sys_root / "devices/system/cpu").glob("cpu[0-9]*/cpufreq/scaling_governor"))
    if not files:
        return ok("cpu governor", "no CPU frequency scaling here (a virtual machine or a container): nothing to set")
    governors = {f.parent.parent.name: f.read_text().strip() for f in files}
    slow = {cpu: g for cpu, g in governors.items() if g != "performance"}
    if not slow:
        return ok("cpu governor", f"performance on all {len(governors)} CPUs")
    jetson = Path("/etc/nv_tegra_release").exists()
    fix = (
        "sudo nvpmodel -m 0 && sudo jetson_clocks (the Orin's full power mode and fixed clocks)"
        if jetson
        else "sudo cpupower frequency-set -g performance (Debian: apt-get install linux-cpupower)"
    )
    kinds = sorted(set(slow.values()))
    return Check(
        "cpu governor",
        Level.WARN,
        f"{len(slow)} of {len(governors)} CPUs on {', '.join(kinds)}: clocks that ramp up late stretch "
        "the control tick",
        fix,
    )


class _Timex(ctypes.Structure):
    """Linux's struct timex (adjtimex(2)), read-only use."""

    _fields_ = [
        ("modes", ctypes.c_uint),
        ("offset", ctypes.c_long),
        ("freq", ctypes.c_long),
        ("maxerror", ctypes.c_long),
        ("esterror", ctypes.c_long),
        ("status", ctypes.c_int),
        ("constant", ctypes.c_long),
        ("precision", ctypes.c_long),
        ("tolerance", ctypes.c_long),
        ("time_sec", ctypes.c_long),
        ("time_usec", ctypes.c_long),
        ("tick", ctypes.c_long),
        ("ppsfreq", ctypes.c_long),
        ("jitter", ctypes.c_long),
        ("shift", ctypes.c_int),
        ("stabil", ctypes.c_long),
        ("jitcnt", ctypes.c_long),
        ("calcnt", ctypes.c_long),
        ("errcnt", ctypes.c_long),
        ("stbcnt", ctypes.c_long),
        ("tai", ctypes.c_int),
        ("padding", ctypes.c_int * 11),
    ]


TIME_ERROR = 5  # adjtimex's answer while the clock is not synchronised


def kernel_clock() -> tuple[bool, float]:
    """(synchronised by NTP or PTP, the kernel's estimated error in seconds), from adjtimex(2) with no changes."""
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    timex = _Timex()
    state = libc.adjtimex(ctypes.byref(timex))
    if state < 0:
        raise OSError(ctypes.get_errno(), "adjtimex failed")
    return state != TIME_ERROR, timex.esterror / 1e6


def check_clock(machine: Machine) -> Check:
    synchronised, error_s = machine.extras.get("clock", kernel_clock)()
    if synchronised:
        return ok("clock", f"synchronised (estimated error {error_s * 1000:.1f} ms)")
    return Check(
        "clock",
        Level.WARN,
        "not synchronised by NTP: sessions are stamped with this clock, and a Jetson without a network "
        "starts from its RTC's time",
        "sudo timedatectl set-ntp true (or install chrony); offline, set it: sudo date -s '2026-11-26 10:00'",
    )


def _existing(path: Path) -> Path:
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def check_disk(machine: Machine) -> Check:
    data = Path(machine.settings.data_dir)
    where = _existing(data)
    usage = shutil.disk_usage(where)
    used_pct = 100.0 * usage.used / usage.total
    thresholds = machine.settings.diagnostics
    detail = f"{data}: {usage.free / 1e9:.1f} GB free of {usage.total / 1e9:.1f} GB ({used_pct:.0f} % used)"
    fix = (
        "free space there, or keep fewer sessions: HUMANOID_SESSION_RETENTION_DAYS / _COUNT, "
        "`humanoid sessions delete ID --yes`"
    )
    if not machine.access(str(where), os.W_OK):
        return Check(
            "disk",
            Level.ERROR,
            f"{detail}; {machine.user()} cannot write in {where}",
            f"sudo chown -R {machine.user()} {where} (the service's own data directory is made for it)",
        )
    if used_pct >= thresholds.disk_error_pct:
        return Check("disk", Level.ERROR, detail + ": recording would stop", fix)
    if used_pct >= thresholds.disk_warn_pct or usage.free < MIN_FREE_BYTES:
        return Check("disk", Level.WARN, detail + ": little room for sessions", fix)
    return ok("disk", detail)
