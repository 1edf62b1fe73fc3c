"""`humanoid bench diagnostics`: what monitoring costs, and how fast faults stop the robot.

- monitor CPU: the diagnostics thread's own CPU time (from the OS, per thread) over `duration_s` of a real-time
  robot with its sensors on, as a percentage of one core; and each 1 Hz sample's CPU time;
- server side: building the JSON every browser receives once a second, and the `/metrics` text;
- fault to safe stop: a servo pushed past its temperature limit (found at the next 1 Hz sample), and a control
  loop that hangs (found by the 20 Hz watchdog once no tick came for 0.5 s), each timed from the injection to the
  diagnostics calling the safe stop.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import psutil

from harness.stats import percentiles

TARGETS = {"monitor_cpu_pct_of_core": 2.0}


def _thread_cpu_s(native_id: int) -> float:
    for thread in psutil.Process().threads():
        if thread.id == native_id:
            return thread.user_time + thread.system_time
    raise RuntimeError(f"no thread {native_id}")


def _time_to_stop(worker: Any, inject: Any) -> float:
    """From the injection to the diagnostics calling the safe stop (its event's time); then clear and release."""
    from robot.interface import Fault, InjectFault, ReleaseEStop

    events = worker.subscribe()
    started = time.time()
    assert worker.submit(inject).accepted
    deadline = time.monotonic() + 10
    stop = None
    while stop is None and time.monotonic() < deadline:
        event = events.get(timeout=0.5)
        if event is not None and event.kind == "diagnostics/safe_stop":
            stop = event
    events.close()
    if stop is None or not worker.wait_for(lambda s: s.estop_latched, 10.0):
        raise RuntimeError(f"{inject} did not stop the robot")
    worker.submit(InjectFault(Fault.CLEAR))
    if inject.fault == Fault.SERVO_HEAT:
        worker.submit(InjectFault(Fault.SERVO_HEAT, inject.target, -inject.value))
    while not worker.submit(ReleaseEStop(source="bench")).accepted and time.monotonic() < deadline + 10:
        time.sleep(0.2)
    worker.wait_for(lambda s: not s.estop_latched, 5.0)
    return stop.wall_time_s - started


def run_diagnostics(duration_s: float = 60.0, seed: int = 0) -> dict[str, Any]:
    from app.diagnostics import diagnostics_json, prometheus_text, snapshot
    from app.runtime import Runtime
    from app.settings import Settings
    from robot.interface import Fault, InjectFault
    from robot.model.world import generate_world
    from robot.worker import RobotWorker

    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="humanoid-bench-diag-") as tmp:
        settings = Settings(
            database_url=f"sqlite:///{Path(tmp) / 'bench.db'}",
            enable_mirror=False,
            seed=seed,
            audio_dir=str(Path(tmp) / "audio"),
        )
        worker = RobotWorker(
            generate_world(seed), realtime=True, perception=True, diagnostics=settings.diagnostics, disk_path=tmp
        )
        runtime = Runtime.start(settings, worker=worker)
        try:
            monitor = worker.health.monitor  # the bench measures the thread itself
            while worker.diagnostics() is None:
                time.sleep(0.1)
            native = monitor.native_thread_id
            cpu0, wall0 = _thread_cpu_s(native), time.perf_counter()
            samples: list[float] = []
            last = None
            while time.perf_counter() - wall0 < duration_s:
                array = worker.diagnostics()
                if array is not last:
                    samples.append(array.monitor_cpu_ms)
                    last = array
                time.sleep(0.05)
            cpu_pct = (_thread_cpu_s(native) - cpu0) / (time.perf_counter() - wall0) * 100.0
            control = worker.state().control
            json_ms, metrics_ms = [], []
            for _ in range(50):
                t0 = time.perf_counter()
                diagnostics_json(snapshot(runtime))
                t1 = time.perf_counter()
                prometheus_text(snapshot(runtime))
                json_ms.append((t1 - t0) * 1e3)
                metrics_ms.append((time.perf_counter() - t1) * 1e3)
            heat_stop = _time_to_stop(worker, InjectFault(Fault.SERVO_HEAT, "r_knee", 60.0))
            stall_stop = _time_to_stop(worker, InjectFault(Fault.CONTROL_STALL, value=1.0))
            statuses = len(worker.diagnostics().statuses)
        finally:
            runtime.stop()
    return {
        "suite": "diagnostics",
        "cpus": psutil.cpu_count(),
        "duration_s": duration_s,
        "statuses": statuses,
        "monitor_cpu_pct_of_core": round(cpu_pct, 3),
        "sample_cpu_ms": percentiles(samples),
        "control_while_monitoring": {"rtf": round(control.rtf, 4), "tick_p99_ms": round(control.tick_p99_ms, 3)},
        "server_json_ms": percentiles(json_ms),
        "server_metrics_ms": percentiles(metrics_ms),
        "overheat_to_safe_stop_s": round(heat_stop, 3),
        "control_stall_to_safe_stop_s": round(stall_stop, 3),
        "bars": {
            "monitor_cpu_pct_of_core": {
                "target": TARGETS["monitor_cpu_pct_of_core"],
                "measured": round(cpu_pct, 3),
                "met": cpu_pct <= TARGETS["monitor_cpu_pct_of_core"],
            }
        },
        "wall_s": round(time.perf_counter() - started, 1),
    }
