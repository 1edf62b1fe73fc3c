"""scripts/estop_trace.py says why a press waited in the page: a starved main thread, and WebGL running meanwhile."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "estop_trace.py"
PAGE, GPU = 10, 20  # process ids
MAIN, COMPOSITOR, GPU_MAIN = 10, 11, 20  # thread ids


@pytest.fixture(scope="module")
def trace_script():
    spec = importlib.util.spec_from_file_location("estop_trace", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def _task(pid: int, tid: int, start_ms: float, wall_ms: float, cpu_ms: float, name: str) -> dict:
    return {
        "ph": "X",
        "pid": pid,
        "tid": tid,
        "name": name,
        "ts": start_ms * 1e3,
        "dur": wall_ms * 1e3,
        "tdur": cpu_ms * 1e3,
    }


def _trace(task_name: str) -> list[dict]:
    meta = [
        {"ph": "M", "pid": PAGE, "tid": MAIN, "name": "process_name", "args": {"name": "Renderer"}},
        {"ph": "M", "pid": GPU, "tid": GPU_MAIN, "name": "process_name", "args": {"name": "GPU Process"}},
        {"ph": "M", "pid": PAGE, "tid": MAIN, "name": "thread_name", "args": {"name": "CrRendererMain"}},
        {"ph": "M", "pid": PAGE, "tid": COMPOSITOR, "name": "thread_name", "args": {"name": "Compositor"}},
        {"ph": "M", "pid": GPU, "tid": GPU_MAIN, "name": "thread_name", "args": {"name": "CrGpuMain"}},
    ]
    press = {"ph": "X", "pid": PAGE, "tid": MAIN, "name": "EventDispatch", "ts": 1000e3, "dur": 100.0,
             "args": {"data": {"type": "pointerdown"}}}  # fmt: skip
    quick = {**press, "ts": 2000e3}
    return [
        *meta,
        # press 1 waited 20 ms (980-1000 ms): the main thread ran a task for all of it but got 4 ms of CPU,
        # while the GPU process ran WebGL from 970 to 990 ms
        _task(PAGE, MAIN, 980, 20, 4, task_name),
        _task(GPU, GPU_MAIN, 970, 20, 1, "WebGL"),
        press,
        # press 2 waited 2 ms, with nothing running
        quick,
        _task(PAGE, COMPOSITOR, 1500, 10, 10, task_name),
    ]


def test_a_starved_main_thread_and_the_webgl_beside_it_are_told_apart(trace_script) -> None:
    result = trace_script.explain_waits(_trace(trace_script.TASK), [20.0, 2.0])
    slow, quick = result["per_press"]
    assert slow == {"wait_ms": 20.0, "main_thread_busy_ms": 20.0, "main_thread_cpu_ms": 4.0, "gpu_webgl_ms": 10.0}
    assert quick == {"wait_ms": 2.0, "main_thread_busy_ms": 0.0, "main_thread_cpu_ms": 0.0, "gpu_webgl_ms": 0.0}
    assert result["slow_waits"] == 1 and result["slow_waits_with_webgl_running"] == 1
    assert result["slow_waits_main_thread_cpu_share"] == pytest.approx(0.2)
    # the trace spans 970..2000 ms: the compositor's 10 ms of CPU is ~1 % of a core, the page's 4 ms ~0.4 %
    threads = result["cpu_percent_of_a_core_by_thread"]
    assert threads[f"Renderer Compositor ({PAGE}:{COMPOSITOR})"] == pytest.approx(1.0, abs=0.05)
    assert threads[f"Renderer CrRendererMain ({PAGE}:{MAIN})"] == pytest.approx(0.4, abs=0.05)


def test_a_trace_without_a_press_is_refused(trace_script) -> None:
    with pytest.raises(ValueError, match="no pointerdown"):
        trace_script.explain_waits([e for e in _trace(trace_script.TASK) if e["name"] != "EventDispatch"], [])
