"""What a `humanoid serve` costs before anyone uses it: each of its processes' CPU to start (until it answers) and
while idle (no page open), as shares of one core.

    .venv/bin/python scripts/idle_cpu.py --seconds 20 [--no-views]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import psutil

from harness.server import ServerProcess

SETTLE_S = 8.0  # after it answers: the robot stands, the sensors start


def _role(process: psutil.Process, server: ServerProcess) -> str:
    """Which of the server's processes this is: by its command line, or (the two it spawns the same way) by whether
    it listens on the 3D view's port."""
    if process.pid == server.pid:
        return "web server"
    line = " ".join(process.cmdline())
    for needle, role in (
        ("sensor_process", "sensors"),
        ("gait_process", "gait"),
        ("recognizer_process", "speech recogniser"),
        ("resource_tracker", "multiprocessing's resource tracker"),
    ):
        if needle in line:
            return role
    listening = {c.laddr.port for c in process.net_connections("tcp") if c.status == psutil.CONN_LISTEN}
    return "3D mirrors" if server.viser_port in listening else "robot"


def _cpu(server: ServerProcess) -> dict[int, tuple[str, float]]:
    root = psutil.Process(server.pid)
    times = {}
    for process in [root, *root.children(recursive=True)]:
        try:
            used = process.cpu_times()
            times[process.pid] = (_role(process, server), used.user + used.system)
        except psutil.Error:
            pass
    return times


def measure(seconds: float, views: bool = True) -> dict:
    with tempfile.TemporaryDirectory() as tmp, ServerProcess(Path(tmp), views=views) as server:
        started = _cpu(server)
        time.sleep(SETTLE_S)
        before = _cpu(server)
        time.sleep(seconds)
        after = _cpu(server)
    idle = {
        f"{role} ({pid})": round((used - before.get(pid, (role, 0.0))[1]) / seconds * 100, 1)
        for pid, (role, used) in after.items()
    }
    return {
        "start_cpu_s": {f"{role} ({pid})": round(used, 1) for pid, (role, used) in started.items()},
        "idle_percent_of_a_core": idle,
        "idle_total_percent_of_a_core": round(sum(idle.values()), 1),
        "seconds": seconds,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--no-views", action="store_true", help="serve without the 3D views (as most tests do)")
    args = parser.parse_args()
    print(json.dumps(measure(args.seconds, views=not args.no_views), indent=2))


if __name__ == "__main__":
    main()
