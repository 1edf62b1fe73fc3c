"""Run a command and say which kinds of process it started used the CPU: the CPU time of the command and of every
process it starts (its descendants) is read from /proc once a second (one that lives less than a second is missed),
then summed by kind.

    .venv/bin/python scripts/cpu_by_process.py -- .venv/bin/python -m pytest -q -n 2 --dist loadfile
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections import defaultdict

TICKS = os.sysconf("SC_CLK_TCK")
KINDS = (  # (a piece of the command line, the kind), first match wins
    ("pytest", "pytest (main)"),
    ("exec(eval(sys.stdin", "pytest workers (in-process robots, speech, ...)"),
    ("app.cli serve", "web servers"),
    ("sensor_process", "sensor processes"),
    ("gait_process", "gait processes"),
    ("recognizer_process", "speech recognisers"),
    ("llama_cpp.server", "llama.cpp's server"),
    ("--type=gpu", "Chromium GPU"),
    ("--type=renderer", "Chromium renderers"),
    ("chrom", "Chromium (other)"),
    ("spawn_main", "spawned (robot and mirror processes)"),
    ("app.cli", "humanoid command line"),
    ("bin/humanoid", "humanoid command line"),
)


def _read(pid: str) -> tuple[tuple[int, int], int, float, str] | None:
    """((pid, start time), parent pid, CPU seconds, command line) of one process, or None if it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            stat = f.read()
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            line = f.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2 :].split()
    return (int(pid), int(fields[19])), int(fields[1]), (int(fields[11]) + int(fields[12])) / TICKS, line


def kind(command_line: str) -> str:
    return next((k for needle, k in KINDS if needle in command_line), "other")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    seen: dict[tuple[int, int], tuple[float, str]] = {}
    started = time.time()
    child = subprocess.Popen(command)
    ours = {child.pid}
    while child.poll() is None:
        processes = [read for pid in filter(str.isdigit, os.listdir("/proc")) if (read := _read(pid)) is not None]
        grew = True
        while grew:  # (a parent may be listed after its child)
            grew = False
            for (pid, _), parent, _, _ in processes:
                if parent in ours and pid not in ours:
                    ours.add(pid)
                    grew = True
        for key, _, cpu, line in processes:
            if key[0] in ours:
                seen[key] = (cpu, seen.get(key, (0.0, line))[1])
        time.sleep(1.0)
    by_kind: dict[str, float] = defaultdict(float)
    count: dict[str, int] = defaultdict(int)
    for cpu, line in seen.values():
        by_kind[kind(line)] += cpu
        count[kind(line)] += 1
    summary = {
        "command": command,
        "wall_s": round(time.time() - started, 1),
        "exit_code": child.returncode,
        "cpu_s_by_kind": {
            k: {"cpu_s": round(v, 1), "processes": count[k]} for k, v in sorted(by_kind.items(), key=lambda kv: -kv[1])
        },
    }
    print(json.dumps(summary, indent=2), file=sys.stderr)
    sys.exit(child.returncode)


if __name__ == "__main__":
    main()
