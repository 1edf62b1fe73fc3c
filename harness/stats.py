"""Summaries of measured values, as every bench and rig reports them."""

from __future__ import annotations

import numpy as np


def percentiles(values: list[float]) -> dict[str, float]:
    """n, p50, p99, max and mean of `values`, rounded to 3 decimals."""
    data = np.asarray(values, dtype=float)
    return {
        "n": int(data.size),
        "p50": round(float(np.percentile(data, 50)), 3),
        "p99": round(float(np.percentile(data, 99)), 3),
        "max": round(float(data.max()), 3),
        "mean": round(float(data.mean()), 3),
    }
