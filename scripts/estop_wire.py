"""Where a slow e-stop from a real browser waits, split on the wire: each press's time in the page (the event
waiting for its handler), from the handler to its first packet on loopback (Chromium's network path), from that
packet to the server's event loop taking it, and from there to the control loop applying it.

The packets' times come from tcpdump on loopback (Debian `tcpdump`, run as root), so the split needs no change to
the page or the server. Set up as `humanoid bench core` presses: a server, two Chromium pages with their 3D views.

    .venv/bin/python scripts/estop_wire.py --presses 100 --output estop-wire.json
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from harness.browser import launch_chromium
from harness.estop_presses import open_watching_pages, press_and_release
from harness.server import ServerProcess
from harness.stats import percentiles


def _packets(lines: list[str]) -> list[tuple[float, int]]:
    """(time, payload bytes) of each page-to-server segment that carried data, from `tcpdump -tt -n` lines."""
    packets = []
    for line in lines:
        fields = line.split()
        try:
            t = float(fields[0])
            length = int(line.rsplit("length", 1)[1].split()[0].strip(":"))
        except (ValueError, IndexError):
            continue
        if length > 0:
            packets.append((t, length))
    return packets


def split_presses(events: list[dict], waits: list[float], packets: list[tuple[float, int]]) -> list[dict[str, Any]]:
    """Each press (its `estop/latched` event and the page's wait) split at its first packet on the wire."""
    presses = []
    for event, wait in zip(events, waits, strict=False):
        data = event["data"]
        applied = event["wall_time_s"]
        handler = applied - data["latency_ms"] / 1e3 + wait / 1e3
        received = applied - data["server_latency_ms"] / 1e3
        first = min((t for t, _ in packets if handler - 0.001 <= t <= received + 0.001), default=None)
        presses.append(
            {
                "total_ms": data["latency_ms"],
                "in_page_ms": wait,
                "handler_to_wire_ms": None if first is None else (first - handler) * 1e3,
                "wire_to_server_ms": None if first is None else (received - first) * 1e3,
                "server_to_applied_ms": data["server_latency_ms"],
                "first_path": data["source"],
            }
        )
    return presses


def measure(presses: int) -> dict[str, Any]:
    from playwright.sync_api import sync_playwright

    if not shutil.which("tcpdump"):
        raise SystemExit("needs tcpdump (apt-get install tcpdump) and root")
    with tempfile.TemporaryDirectory() as tmp, ServerProcess(Path(tmp)) as server, sync_playwright() as p:
        browser = launch_chromium(p)
        pages = open_watching_pages(browser, server.url)
        operator = pages[0]
        capture = Path(tmp) / "lo.txt"
        dump = subprocess.Popen(
            ["tcpdump", "-i", "lo", "-tt", "-n", "-l", f"tcp dst port {server.port} and tcp[tcpflags] & tcp-push != 0"],
            stdout=capture.open("w"),
            stderr=subprocess.DEVNULL,
        )
        time.sleep(1.0)  # (tcpdump listening)
        latched: dict[float, dict] = {}
        for i in range(presses):
            press_and_release(operator, server, i)
            if i % 10 == 9 or i == presses - 1:  # (the server keeps its recent events only)
                for event in server.get("/api/events"):
                    if event["kind"] == "estop/latched":
                        latched[event["wall_time_s"]] = event
        dump.terminate()
        dump.wait()
        waits = [float(w) for w in operator.evaluate("window.humanoid.estopWaits")]
        events = [latched[t] for t in sorted(latched)]
        browser.close()
    split = split_presses(events, waits, _packets(capture.read_text().splitlines()))
    parts = ("total_ms", "in_page_ms", "handler_to_wire_ms", "wire_to_server_ms", "server_to_applied_ms")
    summary = {k: percentiles([s[k] for s in split if s[k] is not None]) for k in parts}
    slow = sorted((s for s in split if s["total_ms"] > 15.0), key=lambda s: -s["total_ms"])
    return {"presses": len(split), "summary": summary, "slow_presses": slow}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--presses", type=int, default=100)
    parser.add_argument("--output", type=Path)
    args = parser.parse_args()
    result = measure(args.presses)
    text = json.dumps(result, indent=2)
    if args.output:
        args.output.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
