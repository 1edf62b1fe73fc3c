"""`humanoid bench walk`: random velocity scripts in physics; falls, tracking, drift and control tick time.

Each script is a fresh simulator on an open floor (walls would end a long walk, not the controller), run as fast
as the machine allows in a pool of processes. Bars (issue 3): 0 falls over >= 20 scripts of 60 s, mean tracking
error <= 20 %, lateral drift <= 5 cm/m, control tick p99 <= 3 ms.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from robot.control.walk_trial import trial_in_new_sim


def run_walk(scripts: int = 20, duration_s: float = 60.0, seed: int = 0, workers: int | None = None) -> dict[str, Any]:
    workers = workers or max(1, min(scripts, os.cpu_count() or 1))
    started = time.perf_counter()
    seeds = list(range(seed, seed + scripts))
    with ProcessPoolExecutor(workers) as pool:
        trials = list(pool.map(trial_in_new_sim, seeds, [duration_s] * scripts))
    upright = [t for t in trials if not t["fell"]]
    errors = [t["tracking_error"] for t in upright if t["tracking_error"] is not None]
    drifts = [d for t in upright for d in t["lateral_drift_m_per_m"]]
    return {
        "suite": "walk",
        "scripts": scripts,
        "script_duration_s": duration_s,
        "falls": sum(t["fell"] for t in trials),
        "tracking_error_mean": float(np.mean(errors)) if errors else None,
        "tracking_error_max": float(np.max(errors)) if errors else None,
        "lateral_drift_m_per_m_mean": float(np.mean(drifts)) if drifts else None,
        "lateral_drift_m_per_m_max": float(np.max(drifts)) if drifts else None,
        "tick_p50_ms": float(np.median([t["tick_p50_ms"] for t in trials])),
        "tick_p99_ms": float(np.max([t["tick_p99_ms"] for t in trials])),
        "max_tilt_deg": float(np.max([t["max_tilt_deg"] for t in trials])),
        "wall_time_s": time.perf_counter() - started,
        "trials": trials,
    }
