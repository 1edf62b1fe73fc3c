"""`humanoid bench sessions`: what recording costs, how big sessions get, and how fast a long one is reviewed.

1. Recording in real time, as `serve` records: the worker in its own process with its sensors, walking and turning
   under teleop, first for `phase_s` seconds without a recorder and then as long with one (camera frames at 1 Hz).
   Reported: the control loop's RTF and tick p99 in both phases (recording must not change them), the recorder's
   write throughput (rows, samples and bytes per second, commit time p50/p99) and the database's growth per minute.
2. A long session (`session_minutes`, 10 by default) recorded headless as fast as the simulation runs: walking
   scripts with a spoken-style command every minute. Reported: its size per minute.
3. Reviewing it through the real server: the sessions list and the session's detail over HTTP, the replay loading
   it, JSON and MCAP export, and the sessions page in headless Chromium until its timeline is shown and the
   replay has loaded (target <= 1 s). Then the replay plays for 5 s: frames sent per second, and how closely its
   clock follows the wall clock.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

TARGETS = {"page_load_s": 1.0, "rtf_min": 0.99, "replay_fps_min": 25.0}
SCRIPT = ((0.15, 0.0, 0.0), (0.0, 0.0, 0.5), (0.1, 0.0, -0.3), (-0.08, 0.0, 0.0), (0.0, 0.04, 0.0))


def _ms(values: list[float]) -> dict[str, float]:
    data = np.asarray(values or [0.0], dtype=float)
    return {
        "p50": round(float(np.percentile(data, 50)), 2),
        "p99": round(float(np.percentile(data, 99)), 2),
        "max": round(float(data.max()), 2),
    }


def _db_bytes(path: Path) -> int:
    """The database's size with everything written moved from the WAL into it (the WAL file is reused, not
    shrunk, so its size says nothing about what is stored)."""
    import sqlite3

    with sqlite3.connect(path) as connection:
        connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return sum(p.stat().st_size for p in path.parent.glob(path.name + "*") if p.is_file())


def _stored_bytes(factory: Any, session_id: int) -> dict[str, int]:
    from sqlalchemy import func, select

    from app.sessions.models import CameraFrameRow, TelemetryChunkRow

    with factory() as db:
        telemetry = (
            db.scalar(
                select(func.sum(func.length(TelemetryChunkRow.data))).where(TelemetryChunkRow.session_id == session_id)
            )
            or 0
        )
        camera = (
            db.scalar(select(func.sum(func.length(CameraFrameRow.jpeg))).where(CameraFrameRow.session_id == session_id))
            or 0
        )
        frames = db.scalar(select(func.count(CameraFrameRow.id)).where(CameraFrameRow.session_id == session_id)) or 0
    return {"telemetry": int(telemetry), "camera": int(camera), "camera_frames": int(frames)}


def _drive(port: Any, seconds: float, clock: Any) -> None:
    """Teleop in turns through SCRIPT, repeated within the deadman's 300 ms, for `seconds` of `clock`."""
    from robot.interface import Teleop

    start = clock()
    while clock() - start < seconds:
        vx, vy, wz = SCRIPT[int((clock() - start) // 5.0) % len(SCRIPT)]
        port.submit(Teleop(vx=vx, vy=vy, yaw_rate=wz, source="bench"))
        time.sleep(0.1)


def recording_in_real_time(phase_s: float, workdir: Path, seed: int = 0) -> dict[str, Any]:
    from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
    from app.sessions.recorder import SessionRecorder
    from robot.interface import StopTeleop
    from robot.process import WorkerProcess

    db_path = workdir / "realtime.db"
    url = f"sqlite:///{db_path}"
    upgrade_to_head(url)
    engine = make_engine(url)
    factory = make_session_factory(engine)
    worker = WorkerProcess(seed, perception=True)
    worker.start()
    try:
        worker.wait_for(lambda s: s.perception is not None and s.perception.camera_hz > 5, 120.0)
        _drive(worker, phase_s, time.monotonic)
        before = worker.state().control
        size0 = _db_bytes(db_path)
        recorder = SessionRecorder(
            factory, worker, kind="serve", seed=seed, audio_dir=str(workdir / "audio"), camera_hz=1.0
        )
        started = time.monotonic()
        _drive(worker, phase_s, time.monotonic)
        worker.submit(StopTeleop(source="bench"))
        during = worker.state().control
        elapsed = time.monotonic() - started
        stats = recorder.stats
        recorder.close()
        grown = _db_bytes(db_path) - size0
        stored = _stored_bytes(factory, recorder.session_id)
    finally:
        worker.stop()
        engine.dispose()
    return {
        "phase_s": phase_s,
        "control_without_recording": {
            "rtf": round(before.rtf, 4),
            "tick_p99_ms": round(before.tick_p99_ms, 3),
            "deadline_misses": before.deadline_misses,
        },
        "control_while_recording": {
            "rtf": round(during.rtf, 4),
            "tick_p99_ms": round(during.tick_p99_ms, 3),
            "deadline_misses": during.deadline_misses,
        },
        "writes": {
            "commits_per_s": round(stats.commits / elapsed, 2),
            "rows_per_s": round(stats.rows / elapsed, 1),
            "telemetry_samples_per_s": round(stats.telemetry_samples / elapsed, 1),
            "telemetry_kb_per_s": round(stats.telemetry_bytes / elapsed / 1024, 2),
            "commit_ms": _ms(list(stats.commit_ms)),
            "telemetry_gaps": recorder.telemetry_gaps,
        },
        "db_mb_per_minute": round(grown / 1e6 / (elapsed / 60), 3),
        "telemetry_mb_per_minute": round(stored["telemetry"] / 1e6 / (elapsed / 60), 3),
        "camera_mb_per_minute": round(stored["camera"] / 1e6 / (elapsed / 60), 3),
        "camera_kb_per_frame": round(stored["camera"] / 1e3 / max(stored["camera_frames"], 1), 1),
    }


def long_session(minutes: float, db_path: Path, seed: int = 0) -> dict[str, Any]:
    """A session of `minutes` of simulated time, recorded headless."""
    from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
    from app.sessions.recorder import SessionRecorder
    from robot.interface import ResetRobot, RunCommand, StopTeleop
    from robot.model.world import generate_world
    from robot.worker import RobotWorker

    url = f"sqlite:///{db_path}"
    upgrade_to_head(url)
    engine = make_engine(url)
    factory = make_session_factory(engine)
    worker = RobotWorker(generate_world(seed), realtime=False, perception=False)
    recorder = SessionRecorder(
        factory, worker, kind="run", seed=seed, audio_dir=str(db_path.parent / "audio"), camera_hz=0
    )
    started = time.perf_counter()
    worker.start()
    sim_clock = lambda: worker.state().sim_time_s  # noqa: E731
    falls = 0
    try:
        for minute in range(int(np.ceil(minutes))):
            _drive(worker, min(50.0, minutes * 60 - sim_clock()), sim_clock)
            worker.submit(StopTeleop(source="bench"))
            worker.wait_for(lambda s: s.mode.value in ("idle", "fallen"), 120.0)
            if worker.state().fallen:  # stood up again, as an operator would, and the session goes on
                falls += 1
                worker.submit(ResetRobot())
                worker.wait_for(lambda s: not s.fallen and s.mode.value == "idle", 120.0)
            reply = worker.submit(RunCommand(f"say minute {minute + 1} done"))
            recorder.record_command(f"say minute {minute + 1} done", "bench", reply)
            end = min((minute + 1) * 60.0, minutes * 60)
            worker.wait_for(lambda s, end=end: s.sim_time_s >= end, 600.0)
        wall = time.perf_counter() - started
        recorder.close(outcome="succeeded")
    finally:
        worker.stop()
        engine.dispose()
    return {
        "session_id": recorder.session_id,
        "sim_minutes": round(sim_clock() / 60, 2),
        "wall_s": round(wall, 1),
        "falls": falls,
        "mb_per_minute": round(_db_bytes(db_path) / 1e6 / minutes, 3),
    }


def review(workdir: Path, session_id: int) -> dict[str, Any]:
    """The long session through the real server and a real browser."""
    import httpx

    from harness.browser import launch_chromium
    from harness.server import ServerProcess

    out: dict[str, Any] = {}
    with ServerProcess(workdir, extra_env={"HUMANOID_PERCEPTION": "false"}) as server:
        client = httpx.Client(base_url=server.url, timeout=120)

        def timed(method: str, path: str, **kw: Any) -> tuple[float, httpx.Response]:
            t0 = time.perf_counter()
            response = client.request(method, path, **kw)
            response.raise_for_status()
            return round(time.perf_counter() - t0, 3), response

        out["list_s"], _ = timed("GET", "/api/sessions")
        out["detail_s"], detail = timed("GET", f"/api/sessions/{session_id}")
        out["timeline_entries"] = len(detail.json()["timeline"])
        out["replay_load_s"], _ = timed("POST", "/api/replay", json={"session_id": session_id})
        out["replay_reload_s"], _ = timed("POST", "/api/replay", json={"session_id": session_id})
        out["export_json_s"], exported = timed("GET", f"/api/sessions/{session_id}/export?format=json")
        out["export_json_mb"] = round(len(exported.content) / 1e6, 2)
        out["export_mcap_s"], exported = timed("GET", f"/api/sessions/{session_id}/export?format=mcap")
        out["export_mcap_mb"] = round(len(exported.content) / 1e6, 2)
        from playwright.sync_api import sync_playwright

        with sync_playwright() as p:
            browser = launch_chromium(p)
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(server.url + "/sessions")  # warm: the page's own files are cached as a returning user's
            loads = []
            for _ in range(3):
                t0 = time.perf_counter()
                page.goto(f"{server.url}/sessions?id={session_id}")
                page.wait_for_function(
                    "document.querySelectorAll('#timeline li').length > 1 && "
                    "document.getElementById('replay-time').textContent.includes('/')",
                    timeout=60_000,
                )
                loads.append(time.perf_counter() - t0)
            out["page_load_s"] = {"runs": [round(v, 3) for v in loads], "median": round(float(np.median(loads)), 3)}
            before = client.get("/api/replay").json()
            client.post("/api/replay/seek", json={"sim_time_s": before["start_s"] + 60.0})
            client.post("/api/replay/play", json={"speed": 1.0})
            t0, f0 = time.perf_counter(), client.get("/api/replay").json()
            time.sleep(5.0)
            t1, f1 = time.perf_counter(), client.get("/api/replay").json()
            client.post("/api/replay/pause")
            browser.close()
        out["replay"] = {
            "fps": round((f1["frames"] - f0["frames"]) / (t1 - t0), 1),
            "clock_ratio": round((f1["sim_time_s"] - f0["sim_time_s"]) / (t1 - t0), 3),
        }
    return out


def run_sessions(phase_s: float = 30.0, session_minutes: float = 10.0) -> dict[str, Any]:
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-sessions-") as tmp:
        workdir = Path(tmp)
        realtime = recording_in_real_time(phase_s, workdir)
        review_dir = workdir / "review"
        review_dir.mkdir()
        long = long_session(session_minutes, review_dir / "server.db")  # the server of `review` opens this file
        reviewed = review(review_dir, long["session_id"])
    rtf = realtime["control_while_recording"]["rtf"]
    bars = {
        "page_load_s": {
            "target": TARGETS["page_load_s"],
            "measured": reviewed["page_load_s"]["median"],
            "met": reviewed["page_load_s"]["median"] <= TARGETS["page_load_s"],
        },
        "rtf_while_recording": {"target": TARGETS["rtf_min"], "measured": rtf, "met": rtf >= TARGETS["rtf_min"]},
        "replay_fps": {
            "target": TARGETS["replay_fps_min"],
            "measured": reviewed["replay"]["fps"],
            "met": reviewed["replay"]["fps"] >= TARGETS["replay_fps_min"],
        },
    }
    return {
        "suite": "sessions",
        "cpus": os.cpu_count(),
        "recording": realtime,
        "long_session": long,
        "review": reviewed,
        "bars": bars,
        "wall_s": round(time.perf_counter() - started, 1),
    }
