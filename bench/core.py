"""`humanoid bench core`: control-loop timing, real-time factor and e-stop latency with browsers watching.

What is measured, and how:
- control loop: tick duration p50/p99/max over the last 30 s (the default window) and deadline misses, read
  from the server (`/api/health`) while `viewers` headless Chromium pages have the 3D view open;
- real-time factor in `serve`: simulated seconds per wall second over the same window; and headless (as fast as
  possible) from an in-process worker;
- e-stop latency: from the browser's pointer event (its own timestamp) to the control loop applying the stop,
  for `presses` real clicks on the page's E-STOP button, released through the API between presses.
"""

from __future__ import annotations

import os
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

from bench.cpu_share import CpuShare
from harness.browser import launch_chromium
from harness.estop_presses import open_watching_pages, press_and_release
from harness.server import ServerProcess
from harness.stats import percentiles

TARGETS = {"estop_p99_ms": 15.0, "tick_p99_ms": 2.0, "rtf_min": 0.995}


def headless_rtf(sim_seconds: float = 20.0, seed: int = 0) -> dict[str, float]:
    """How fast the simulation runs with the control loop but no pacing (as in `humanoid run`)."""
    from robot.model.world import generate_world
    from robot.worker import RobotWorker

    worker = RobotWorker(generate_world(seed), realtime=False)
    start = time.perf_counter()
    worker.start()
    worker.wait_for(lambda s: s.sim_time_s >= sim_seconds, timeout_s=600)
    wall = time.perf_counter() - start
    sim = worker.state().sim_time_s
    worker.stop()
    return {"sim_s": round(sim, 2), "wall_s": round(wall, 3), "rtf": round(sim / wall, 2)}


def _press_estop(page: Any, server: ServerProcess, presses: int) -> tuple[list[float], dict[str, Any]]:
    for i in range(presses):
        press_and_release(page, server, i)
    latencies = [float(v) for v in page.evaluate("window.humanoid.estopLatencies")]
    return latencies, _where_the_time_goes(page.evaluate("[window.humanoid.estopParts, window.humanoid.estopWaits]"))


def _where_the_time_goes(measured: list[Any]) -> dict[str, Any]:
    """Each press's latency in parts: in the page (the event waiting for its handler on the page's main thread),
    page to server (that wait, then sending: the browser's network service, the kernel, the server's event loop),
    handler to server (the sending alone), server to robot process, and the robot applying it; and which of the
    page's two sockets brought it first."""
    parts, waits = measured
    in_page = [float(w) for w in waits]
    to_server = [p["total"] - p["server"] for p in parts if p.get("server") is not None]
    server_to_robot = [p["server"] - p["robot"] for p in parts if p.get("server") is not None]
    robot = [p["robot"] for p in parts if p.get("robot") is not None]
    sources: dict[str, int] = {}
    for p in parts:
        sources[p.get("source", "?")] = sources.get(p.get("source", "?"), 0) + 1
    # (one wait and one latched event per press, in order)
    sent_to_server = [total - wait for total, wait in zip(to_server, in_page, strict=False)]
    return {
        "event_to_handler_ms": percentiles(in_page) if in_page else None,
        "handler_to_server_ms": percentiles(sent_to_server) if sent_to_server else None,
        "page_to_server_ms": percentiles(to_server) if to_server else None,
        "server_to_robot_ms": percentiles(server_to_robot) if server_to_robot else None,
        "robot_applies_ms": percentiles(robot) if robot else None,
        "first_path": sources,
    }


def run_core(presses: int = 100, viewers: int = 2, duration_s: float = 30.0) -> dict[str, Any]:
    from playwright.sync_api import sync_playwright

    result: dict[str, Any] = {
        "suite": "core",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()},
        "config": {"presses": presses, "viewers": viewers, "duration_s": duration_s},
        "targets": TARGETS,
    }
    result["headless"] = headless_rtf()
    with tempfile.TemporaryDirectory() as tmp, ServerProcess(Path(tmp)) as server, sync_playwright() as p:
        browser = launch_chromium(p)
        pages = open_watching_pages(browser, server.url, viewers)
        operator = pages[0]

        before, wall_before = server.get("/api/health"), time.time()
        time.sleep(duration_s)
        after, wall_after = server.get("/api/health"), time.time()
        control = after["control"]
        rtf = (after["sim_time_s"] - before["sim_time_s"]) / (wall_after - wall_before)
        result["serve"] = {
            "viewers_with_3d_open": len(pages),
            "mirror_updates": {name: m["updates"] for name, m in after["mirrors"].items()},
            "tick_ms": {k: round(control[f"tick_{k}_ms"], 3) for k in ("p50", "p99", "max")},
            "ticks": control["ticks"] - before["control"]["ticks"],
            "deadline_misses": control["deadline_misses"] - before["control"]["deadline_misses"],
            "deadline_misses_since_start": control["deadline_misses"],
            "rtf": round(rtf, 4),
            "sim_lag_ms": round(((wall_after - wall_before) - (after["sim_time_s"] - before["sim_time_s"])) * 1e3, 1),
        }
        with CpuShare() as cpu:
            latencies, parts = _press_estop(operator, server, presses)
        result["cpu_percent_of_a_core_while_pressing"] = cpu.shares()
        result["estop_latency_ms"] = percentiles(latencies)
        result["estop_parts"] = parts
        priority = [e["message"] for e in server.get("/api/events") if e["kind"] == "control/priority"]
        result["serve"]["control_priority"] = priority[0] if priority else "unknown"
        browser.close()

    result["pass"] = {
        "estop_p99": result["estop_latency_ms"]["p99"] <= TARGETS["estop_p99_ms"],
        "tick_p99": result["serve"]["tick_ms"]["p99"] <= TARGETS["tick_p99_ms"],
        "rtf": result["serve"]["rtf"] >= TARGETS["rtf_min"],
    }
    return result
