"""`humanoid bench load`: many viewers and an operator's command and teleop stream on one real server; e-stop
latency and the real-time factor while it lasts.

What is measured, and how:
- the server is `humanoid serve` in its own process (robot worker in another), as users run it;
- each viewer opens what a page opens: the robot WebSocket (`/ws`: state at 20 Hz, events, diagnostics), the
  camera stream (`/ws/camera`) and the 3D mirror's viser WebSocket (half on the full view, half on the light one).
  The viewers are WebSocket clients, not Chromium pages: on 2 cores twenty renderers would measure Chromium, not
  the server. They read everything they are sent, as a page does;
- the operator drives over its own `/ws`: teleop at 10 Hz and heartbeats at 4 Hz, a typed command through
  `POST /api/commands` every few seconds (each planned, and walked until the next e-stop);
- e-stop: the operator sends `{"type": "estop", "client_time_s": now}` at a human pace; the latency is from that
  timestamp to the control loop applying the stop (the worker's `estop/latched` event says when), as the page
  measures it; then released over the same socket;
- real-time factor and tick timing over the loaded window, from `/api/health`.
"""

from __future__ import annotations

import asyncio
import json
import os
import platform
import random
import statistics
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import viser
import websockets

from harness.server import ServerProcess
from harness.stats import percentiles

TARGETS = {"estop_p99_ms": 15.0, "rtf_min": 0.995, "viewers_held": 1.0}
COMMANDS = ("go to the kitchen counter", "go to the living-room table", "go to the charging dock")


@dataclass
class ViewerStats:
    states: int = 0
    camera_frames: int = 0
    mirror_messages: int = 0
    mirror_bytes: int = 0
    connected: bool = False
    error: str = ""


@dataclass
class OperatorStats:
    latencies_ms: list[float] = field(default_factory=list)  # client's timestamp -> applied by the control loop
    server_ms: list[float] = field(default_factory=list)  # the web server relaying it -> applied
    worker_ms: list[float] = field(default_factory=list)  # the robot process receiving it -> applied
    teleops: int = 0
    commands_accepted: int = 0
    commands_refused: int = 0
    refusals: set[str] = field(default_factory=set)


async def _count(socket: Any, on_message: Any, stop: asyncio.Event) -> None:
    while not stop.is_set():
        try:
            message = await asyncio.wait_for(socket.recv(), timeout=0.5)
        except TimeoutError:
            continue
        on_message(message)


async def _viewer(base: str, mirror_url: str, stats: ViewerStats, stop: asyncio.Event) -> None:
    ws_base = base.replace("http://", "ws://")

    def on_robot(message: str | bytes) -> None:
        if isinstance(message, str) and '"state"' in message[:24]:  # (counted without parsing every state)
            stats.states += 1

    def on_camera(message: str | bytes) -> None:
        if isinstance(message, bytes):
            stats.camera_frames += 1

    def on_mirror(message: str | bytes) -> None:
        stats.mirror_messages += 1
        stats.mirror_bytes += len(message)

    try:
        async with (
            websockets.connect(ws_base + "/ws", max_size=None) as robot,
            websockets.connect(ws_base + "/ws/camera", max_size=None) as camera,
            websockets.connect(mirror_url, max_size=None, subprotocols=[f"viser-v{viser.__version__}"]) as mirror,
        ):
            stats.connected = True
            await asyncio.gather(
                _count(robot, on_robot, stop), _count(camera, on_camera, stop), _count(mirror, on_mirror, stop)
            )
    except Exception as exc:  # a viewer dropped is a result, not a crash of the bench
        stats.error = f"{type(exc).__name__}: {exc}"
    finally:
        stats.connected = stats.connected and not stats.error


async def _wait_event(inbox: asyncio.Queue, kind: str, timeout_s: float) -> dict[str, Any]:
    deadline = time.monotonic() + timeout_s
    while (left := deadline - time.monotonic()) > 0:
        message = await asyncio.wait_for(inbox.get(), timeout=left)
        if message.get("type") == "event" and message["event"]["kind"] == kind:
            return message["event"]
    raise TimeoutError(f"no {kind} event within {timeout_s} s")


async def _wait_state(inbox: asyncio.Queue, latched: bool, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while (left := deadline - time.monotonic()) > 0:
        message = await asyncio.wait_for(inbox.get(), timeout=left)
        if message.get("type") == "state" and message["state"]["estop_latched"] == latched:
            return
    raise TimeoutError(f"the e-stop did not become {'latched' if latched else 'released'} within {timeout_s} s")


async def _operator(base: str, presses: int, stats: OperatorStats) -> None:
    ws_base = base.replace("http://", "ws://")
    inbox: asyncio.Queue = asyncio.Queue()
    async with websockets.connect(ws_base + "/ws", max_size=None) as ws, httpx.AsyncClient(base_url=base) as http:
        stop = asyncio.Event()

        async def read() -> None:
            async for raw in ws:
                if isinstance(raw, str):
                    inbox.put_nowait(json.loads(raw))

        async def heartbeat() -> None:
            while not stop.is_set():
                await ws.send(json.dumps({"type": "heartbeat"}))
                await asyncio.sleep(0.25)

        async def drive_and_command() -> None:
            """Turns: two seconds of teleop at 10 Hz, then a typed command (planned; walked until the next e-stop)."""
            while not stop.is_set():
                for _ in range(20):
                    await ws.send(json.dumps({"type": "teleop", "vx": 0.1, "vy": 0.0, "yaw_rate": 0.2}))
                    stats.teleops += 1
                    await asyncio.sleep(0.1)
                await ws.send(json.dumps({"type": "teleop_stop"}))
                await asyncio.sleep(1.5)  # the walk ends its step before teleop is over
                for _ in range(10):  # as an operator would: again, when it was refused (an e-stop just then)
                    response = await http.post("/api/commands", json={"text": random.choice(COMMANDS)}, timeout=30)
                    if response.status_code == 202:
                        stats.commands_accepted += 1
                        break
                    stats.commands_refused += 1
                    stats.refusals.add(response.json().get("detail", {}).get("message", response.text)[:100])
                    await asyncio.sleep(0.3)
                await asyncio.sleep(random.uniform(1.0, 3.0))

        reader = asyncio.create_task(read())
        background = [asyncio.create_task(heartbeat()), asyncio.create_task(drive_and_command())]
        try:
            for _ in range(presses):
                await asyncio.sleep(random.uniform(0.2, 0.6))  # a human's pace, not phase-locked with the ticks
                while not inbox.empty():
                    inbox.get_nowait()
                await ws.send(json.dumps({"type": "estop", "client_time_s": time.time()}))
                latched = await _wait_event(inbox, "estop/latched", 10.0)
                stats.latencies_ms.append(float(latched["data"]["latency_ms"]))
                stats.server_ms.append(float(latched["data"]["server_latency_ms"]))
                stats.worker_ms.append(float(latched["data"]["worker_latency_ms"]))
                await ws.send(json.dumps({"type": "estop_release"}))
                await _wait_state(inbox, False, 10.0)
        finally:
            stop.set()
            for task in background:
                await task
            reader.cancel()


async def _load(
    base: str, mirror_ports: tuple[int, int], viewers: int, presses: int, settle_s: float
) -> tuple[list[ViewerStats], OperatorStats, float]:
    stop = asyncio.Event()
    watching = [ViewerStats() for _ in range(viewers)]
    token = httpx.get(base + "/api/scene", timeout=10).json()["token"]  # (the 3D views' gates admit a login)
    urls = [f"ws://127.0.0.1:{port}/s/{token}" for port in mirror_ports]
    tasks = [asyncio.create_task(_viewer(base, urls[i % 2], s, stop)) for i, s in enumerate(watching)]
    await asyncio.sleep(settle_s)  # every viewer connected and its first scene sent
    operator = OperatorStats()
    started = time.monotonic()
    await _operator(base, presses, operator)
    loaded_s = time.monotonic() - started
    stop.set()
    await asyncio.gather(*tasks)
    return watching, operator, loaded_s


def run_load(viewers: int = 20, presses: int = 100) -> dict[str, Any]:
    result: dict[str, Any] = {
        "suite": "load",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()},
        "config": {
            "viewers": viewers,
            "presses": presses,
            "viewer": "/ws + /ws/camera + viser WebSocket",
            "operator": "heartbeat 4 Hz; in turns, 2 s of teleop at 10 Hz, then a typed command",
        },
        "targets": TARGETS,
    }
    with tempfile.TemporaryDirectory() as tmp, ServerProcess(Path(tmp)) as server:
        before, wall_before = server.get("/api/health"), time.time()
        watching, operator, loaded_s = asyncio.run(
            _load(server.url, (server.viser_port, server.viser_light_port), viewers, presses, settle_s=5.0)
        )
        after, wall_after = server.get("/api/health"), time.time()
        health_status = httpx.get(server.url + "/api/health", timeout=5).status_code
    control = after["control"]
    rtf = (after["sim_time_s"] - before["sim_time_s"]) / (wall_after - wall_before)
    held = [v for v in watching if v.connected]
    window = wall_after - wall_before
    state_hz = [v.states / window for v in watching]
    result["viewers"] = {
        "connected": viewers,
        "held_to_the_end": len(held),
        "errors": sorted({v.error for v in watching if v.error}),
        "state_hz_min": round(min(state_hz), 2) if state_hz else 0.0,
        "state_hz_median": round(statistics.median(state_hz), 2) if state_hz else 0.0,
        "camera_fps_median": round(statistics.median(v.camera_frames / window for v in watching), 2),
        "mirror_kb_s_median": round(statistics.median(v.mirror_bytes / window / 1e3 for v in watching), 1),
    }
    result["operator"] = {
        "teleop_messages": operator.teleops,
        "commands_accepted": operator.commands_accepted,
        "commands_refused": operator.commands_refused,
        "refusal_reasons": sorted(operator.refusals),
        "loaded_s": round(loaded_s, 1),
    }
    result["estop_latency_ms"] = percentiles(operator.latencies_ms)
    received = [a - b for a, b in zip(operator.latencies_ms, operator.server_ms, strict=True)]
    relayed = [a - b for a, b in zip(operator.server_ms, operator.worker_ms, strict=True)]
    result["estop_latency_parts_ms"] = {
        "client_to_server": percentiles(received),
        "server_to_robot_process": percentiles(relayed),
        "robot_process_to_applied": percentiles(operator.worker_ms),
    }
    result["serve"] = {
        "rtf": round(rtf, 4),
        "window_s": round(window, 1),
        "tick_ms": {k: round(control[f"tick_{k}_ms"], 3) for k in ("p50", "p99", "max")},
        "deadline_misses": control["deadline_misses"] - before["control"]["deadline_misses"],
        "health_after": health_status,
    }
    result["pass"] = {
        "estop_p99": result["estop_latency_ms"]["p99"] <= TARGETS["estop_p99_ms"],
        "rtf": rtf >= TARGETS["rtf_min"],
        "viewers_held": len(held) >= TARGETS["viewers_held"] * viewers,
    }
    return result
