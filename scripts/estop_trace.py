"""Why a browser e-stop press waits in the page, from a Chromium performance trace of the operator's page.

For each press the page reports how long the pointer event waited for its handler (`humanoid.estopWaits`). This
script records a trace while pressing (set up as `humanoid bench core` presses: a server, two Chromium pages with
their 3D views) and says, for each wait, how long the page's main thread was running tasks in it, how much CPU
those tasks got (a thread that runs but gets no core is being starved, not slow), and how long the GPU process was
executing WebGL commands (the 3D views, drawn in software) at the same time. It also gives each busy thread's CPU.
Tracing itself loads the page: compare the shares, not the waits, with `humanoid bench core`.

    .venv/bin/python scripts/estop_trace.py --presses 40 --output estop-trace.json
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from harness.browser import launch_chromium
from harness.estop_presses import open_watching_pages, press_and_release
from harness.server import ServerProcess
from harness.stats import percentiles

CATEGORIES = ["toplevel", "input", "latencyInfo", "blink", "v8.execute", "gpu", "devtools.timeline"]
TASK = "ThreadControllerImpl::RunTask"  # one top-level task of a Chromium thread
WEBGL = "WebGL"  # the GPU process running a page's WebGL commands
SLOW_WAIT_MS = 10.0


def _overlap(start: float, end: float, spans: list[tuple[float, float, float]]) -> tuple[float, float]:
    """(wall, CPU) microseconds of `spans` (start, end, CPU) inside [start, end]; CPU pro rata."""
    wall = cpu = 0.0
    for a, b, c in spans:
        inside = min(b, end) - max(a, start)
        if inside > 0:
            wall += inside
            cpu += c * inside / max(b - a, 1.0)
    return wall, cpu


def explain_waits(events: list[dict[str, Any]], waits_ms: list[float]) -> dict[str, Any]:
    """Each press's wait in the page, next to what its main thread and the GPU process did meanwhile.

    `events` are the trace's events; `waits_ms` the page's own waits, one per press in order. The presses are
    the trace's `pointerdown` dispatches, in order; the thread that ran them is the page's main thread.
    """
    names = {
        (e["pid"], e["tid"]): e["args"]["name"] for e in events if e.get("ph") == "M" and e["name"] == "thread_name"
    }
    processes = {e["pid"]: e["args"]["name"] for e in events if e.get("ph") == "M" and e["name"] == "process_name"}
    presses = sorted(
        (
            e
            for e in events
            if e.get("name") == "EventDispatch" and e["args"].get("data", {}).get("type") == "pointerdown"
        ),
        key=lambda e: e["ts"],
    )
    if not presses:
        raise ValueError("no pointerdown in the trace")
    main = (presses[0]["pid"], presses[0]["tid"])
    spans: dict[tuple[int, int], list[tuple[float, float, float]]] = {}
    webgl: list[tuple[float, float, float]] = []
    for e in events:
        if e.get("ph") != "X":
            continue
        span = (e["ts"], e["ts"] + e.get("dur", 0), e.get("tdur", 0))
        if e["name"] == TASK:
            spans.setdefault((e["pid"], e["tid"]), []).append(span)
        elif e["name"] == WEBGL and processes.get(e["pid"]) == "GPU Process":
            webgl.append(span)
    rows = []
    for press, wait in zip(presses, waits_ms, strict=False):
        end = press["ts"]
        start = end - wait * 1e3
        wall, cpu = _overlap(start, end, spans.get(main, []))
        gpu, _ = _overlap(start, end, webgl)
        rows.append(
            {
                "wait_ms": round(wait, 2),
                "main_thread_busy_ms": round(wall / 1e3, 2),
                "main_thread_cpu_ms": round(cpu / 1e3, 2),
                "gpu_webgl_ms": round(gpu / 1e3, 2),
            }
        )
    times = [e["ts"] for e in events if e.get("ph") == "X"]
    seconds = max((max(times) - min(times)) / 1e6, 1e-9)
    cpu_by_thread = Counter()
    for key, thread_spans in spans.items():
        label = f"{processes.get(key[0], '?')} {names.get(key, '?')} ({key[0]}:{key[1]})"
        cpu_by_thread[label] = sum(c for _, _, c in thread_spans) / 1e3 / seconds / 10.0  # % of a core
    slow = [r for r in rows if r["wait_ms"] > SLOW_WAIT_MS]
    return {
        "presses": len(rows),
        "wait_ms": percentiles([r["wait_ms"] for r in rows]),
        "slow_waits": len(slow),
        "slow_waits_main_thread_cpu_share": (
            round(sum(r["main_thread_cpu_ms"] for r in slow) / sum(r["wait_ms"] for r in slow), 3) if slow else None
        ),
        "slow_waits_with_webgl_running": sum(1 for r in slow if r["gpu_webgl_ms"] > 0),
        "gpu_webgl_busy_share": round(sum(b - a for a, b, _ in webgl) / 1e6 / seconds, 3),
        "cpu_percent_of_a_core_by_thread": {k: round(v, 1) for k, v in cpu_by_thread.most_common(12)},
        "per_press": rows,
    }


def record(presses: int, trace_path: Path) -> list[float]:
    """Press the operator page's E-STOP `presses` times while Chromium traces; returns the page's waits (ms)."""
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp, ServerProcess(Path(tmp)) as server, sync_playwright() as p:
        browser = launch_chromium(p)
        pages = open_watching_pages(browser, server.url)
        operator = pages[0]
        browser.start_tracing(page=operator, path=str(trace_path), categories=CATEGORIES)
        for i in range(presses):
            press_and_release(operator, server, i)
        browser.stop_tracing()
        waits = [float(w) for w in operator.evaluate("window.humanoid.estopWaits")]
        browser.close()
    return waits


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--presses", type=int, default=40)
    parser.add_argument("--output", type=Path)
    parser.add_argument("--keep-trace", type=Path, help="also keep the raw trace (large: ~5 MB a second)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        trace_path = args.keep_trace or Path(tmp) / "trace.json"
        waits = record(args.presses, trace_path)
        trace = json.loads(trace_path.read_text())
    result = explain_waits(trace["traceEvents"] if isinstance(trace, dict) else trace, waits)
    text = json.dumps(result, indent=2)
    if args.output:
        args.output.write_text(text)
    print(json.dumps({k: v for k, v in result.items() if k != "per_press"}, indent=2))


if __name__ == "__main__":
    main()
