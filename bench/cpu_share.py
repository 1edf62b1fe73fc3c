"""Who uses the CPU while a benchmark runs: each process's share of one core, grouped by what it is (the web
server, the robot, its sensors, the 3D views, each kind of browser process, everything else). On two cores the
e-stop's path (a browser renderer, the browser's network service, the web server, the robot process) waits
for whatever else is runnable: this says what that is."""

from __future__ import annotations

import os
import threading
import time
from collections import defaultdict

import psutil

PERIOD_S = 0.5


def kind_of(process: psutil.Process) -> str:
    """A short name for what a process is, from its command line."""
    try:
        cmdline = " ".join(process.cmdline())
    except (psutil.Error, OSError):
        return "gone"
    if "chromium" in cmdline or "chrome" in cmdline:
        for kind in ("renderer", "gpu-process", "utility", "zygote"):
            if f"--type={kind}" in cmdline:
                return f"browser {kind}"
        return "browser main"
    for needle, kind in (
        ("sensor_process", "robot sensors"),
        ("app.cli serve", "web server"),
        ("humanoid serve", "web server"),
    ):
        if needle in cmdline:
            return kind
    if "multiprocessing" in cmdline:  # the server's children: told apart by how they are scheduled
        try:
            if process.nice() > 0:
                return "3D views (mirrors and gates)"
            if os.sched_getscheduler(process.pid) == os.SCHED_FIFO:
                return "robot"
        except (psutil.Error, OSError):
            return "gone"
        return "server child"
    return "other"


class CpuShare:
    """Samples every process's CPU time while running; `shares()` is % of one core per kind, averaged."""

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="cpu-share", daemon=True)
        self._seconds: dict[str, float] = defaultdict(float)
        self._wall = 0.0

    def __enter__(self) -> CpuShare:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    def _run(self) -> None:
        last: dict[int, tuple[str, float]] = {}
        started = time.monotonic()
        while not self._stop.wait(PERIOD_S):
            now: dict[int, tuple[str, float]] = {}
            for process in psutil.process_iter():
                try:
                    times = process.cpu_times()
                    used = times.user + times.system
                    kind = last[process.pid][0] if process.pid in last else kind_of(process)
                except (psutil.Error, OSError):
                    continue
                now[process.pid] = (kind, used)
                if process.pid in last:
                    self._seconds[kind] += max(0.0, used - last[process.pid][1])
            last = now
            self._wall = time.monotonic() - started

    def shares(self) -> dict[str, float]:
        """% of one core per kind of process, largest first (two cores: up to 200 % in all)."""
        if self._wall <= 0:
            return {}
        shares = {kind: round(100.0 * seconds / self._wall, 1) for kind, seconds in self._seconds.items()}
        return dict(sorted(shares.items(), key=lambda item: -item[1]))
