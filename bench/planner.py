"""`humanoid bench planner`: each backend over the paraphrase suite: how often its plan is exactly right, how
often it needed a repair or the rules fallback, and how long planning takes (p50/p99 per backend).

Target: `rules` p99 <= 20 ms. LLM backends are measured where configured (HUMANOID_OPENAI_*, HUMANOID_LOCAL_*);
one that cannot be reached is reported as unavailable, with the reason, not skipped silently.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from app.settings import Settings
from harness.planner_cases import CASES, context_for, plan_matches
from robot.model.world import generate_world
from robot.planning.pipeline import BACKENDS, build_pipeline
from robot.planning.planner import PlanningError

RULES_P99_TARGET_MS = 20.0


def run_planner(settings: Settings, backends: tuple[str, ...], repeat: int = 1, no_fallback: bool = False) -> dict:
    layout = generate_world(0)
    results: dict[str, Any] = {}
    for backend in backends:
        config = settings.model_copy(update={"planner_backend": backend}).planner_config()
        if no_fallback:
            config = type(config)(**{**config.__dict__, "fallback_to_rules": False})
        pipeline = build_pipeline(config)
        if pipeline.primary is None:
            results[backend] = {"available": False, "reason": pipeline.unavailable}
            continue
        results[backend] = _measure(pipeline, layout, repeat)
        results[backend]["model"] = pipeline.describe()
    rules = results.get("rules")
    bars = {}
    if rules and rules.get("available"):
        p99, exact = rules["latency_ms"]["p99"], rules["exact_rate"]
        bars = {
            "rules_p99_ms": {"target": RULES_P99_TARGET_MS, "measured": p99, "met": p99 <= RULES_P99_TARGET_MS},
            "rules_exact": {"target": 0.95, "measured": exact, "met": exact >= 0.95},
        }
    return {"suite": "planner", "cases": len(CASES), "repeat": repeat, "backends": results, "bars": bars}


def _measure(pipeline: Any, layout: Any, repeat: int) -> dict[str, Any]:
    latencies: list[float] = []
    exact = exact_overall = fallbacks = repaired = failed = 0
    wrong: list[dict[str, Any]] = []
    for case in CASES:
        for attempt in range(repeat):
            context = context_for(case, layout)
            started = time.perf_counter()
            try:
                result = pipeline.plan(case.text, context)
            except PlanningError as exc:
                latencies.append(time.perf_counter() - started)
                failed += 1
                if attempt == 0:
                    wrong.append({"text": case.text, "error": str(exc)[:300]})
                continue
            latencies.append(time.perf_counter() - started)
            got = result.plan.to_seed_list()
            fallbacks += result.planner != result.backend
            repaired += result.planner == result.backend and result.attempts > 1
            right = plan_matches(case.plan, got)
            exact_overall += right
            if right and result.planner == result.backend:
                exact += 1
            if not right and attempt == 0:
                wrong.append({"text": case.text, "plan": got, "planner": result.planner, "notes": list(result.notes)})
    runs = len(CASES) * repeat
    ms = np.asarray(latencies) * 1000.0
    return {
        "available": True,
        "runs": runs,
        # the backend's own plans only: a plan the rules fallback made does not count for the backend
        "exact_rate": round(exact / runs, 4),
        "exact": exact,
        "exact_rate_with_fallback": round(exact_overall / runs, 4),
        "no_plan": failed,
        "fell_back_to_rules": fallbacks,
        "repaired": repaired,
        "latency_ms": {
            "p50": round(float(np.percentile(ms, 50)), 3),
            "p99": round(float(np.percentile(ms, 99)), 3),
            "max": round(float(ms.max()), 3),
            "mean": round(float(ms.mean()), 3),
        },
        "wrong": wrong,
    }


def parse_backends(text: str) -> tuple[str, ...]:
    backends = tuple(b.strip() for b in text.split(",") if b.strip())
    unknown = [b for b in backends if b not in BACKENDS]
    if unknown or not backends:
        raise ValueError(f"unknown backend(s) {unknown or text!r}: choose from {', '.join(BACKENDS)}")
    return backends
