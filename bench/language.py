"""`humanoid bench language`: how well commands in everyday wording are understood, per set of commands and per
planner: the share planned right (everyday wording, close paraphrases of the README's examples), out-of-world
requests refused, questions asked, and how long planning takes.

Two sets (`language_dev`, tuned on; `language_heldout`, written first and never tuned on) are reported apart, and
the bars must hold on both. With `spoken_sets` (`--spoken dev,heldout21`), the same figures for those sets spoken
(`bench/spoken.py`: espeak-ng voices, clean and in noise), per recogniser and planner, beside the typed ones.
LLM backends are measured only where configured (HUMANOID_OPENAI_*, HUMANOID_LOCAL_MODEL_PATH, or --backends).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np

from app.settings import Settings
from harness.language_cases import BARS, CLARIFY, KINDS, LanguageCase, Outcome, plan_case
from harness.language_dev import DEV
from harness.language_heldout import HELDOUT
from robot.model.world import WorldLayout, generate_world
from robot.planning.pipeline import PlanningPipeline, build_pipeline

SETS: dict[str, tuple[LanguageCase, ...]] = {"dev": DEV, "heldout": HELDOUT}


def configured_backends(settings: Settings) -> tuple[str, ...]:
    """rules, and every LLM backend the settings point at."""
    backends = ["rules"]
    if (
        settings.openai_api_key
        or "openai_base_url" in settings.model_fields_set
        or settings.planner_backend == "openai"
    ):
        backends.append("openai")
    if settings.local_model_path:
        backends.append("local")
    return tuple(backends)


def run_language(
    settings: Settings,
    backends: tuple[str, ...] | None = None,
    no_fallback: bool = False,
    spoken_sets: tuple[str, ...] = (),
    engines: tuple[str, ...] = ("whisper", "pocketsphinx"),
    quick: bool = False,
) -> dict:
    layout = generate_world(0)
    backends = backends or configured_backends(settings)
    typed: dict[str, dict[str, Any]] = {name: {} for name in SETS}
    pipelines: dict[str, PlanningPipeline] = {}
    for backend in backends:
        config = settings.model_copy(update={"planner_backend": backend}).planner_config()
        if no_fallback:
            config = type(config)(**{**config.__dict__, "fallback_to_rules": False})
        pipeline = build_pipeline(config)
        for set_name, cases in SETS.items():
            if pipeline.primary is None:
                typed[set_name][backend] = {"available": False, "reason": pipeline.unavailable}
                continue
            typed[set_name][backend] = {**measure(pipeline, backend, cases, layout), "model": pipeline.describe()}
        if pipeline.primary is not None:
            pipelines[backend] = pipeline
    spoken = (
        measure_spoken(spoken_sets, engines, pipelines, quick)
        if spoken_sets
        else {"measured": False, "how": HOW_SPOKEN}
    )
    return {
        "suite": "language",
        "sets": {name: dict(Counter(c.kind for c in cases)) for name, cases in SETS.items()},
        "typed": typed,
        "spoken": spoken,
        "bars": {**_bars(typed), **spoken.get("bars", {})},
    }


HOW_SPOKEN = "humanoid bench language --spoken dev,heldout21 (about 9 min a set with whisper), or humanoid bench speech"


def measure_spoken(
    set_names: tuple[str, ...],
    engines: tuple[str, ...],
    pipelines: dict[str, PlanningPipeline],
    quick: bool = False,
) -> dict[str, Any]:
    """The spoken sets heard by each engine and planned by each planner: per set, engine and planner, the spoken
    figures of `humanoid bench speech` (plans right, word error rate, stops, requests out of the world, end of
    speech to plan), and the spoken bars for each. `quick`: a few utterances of each set, clean (as `bench speech
    --quick`: shows it works; its figures mean little)."""
    from bench.spoken import NOISY_SNR_DB, few, run_set, speech_bars, summarise
    from harness.spoken_cases import SETS as SPOKEN_SETS

    snrs = (None,) if quick else (None, NOISY_SNR_DB)

    figures: dict[str, dict[str, dict[str, Any]]] = {}
    bars: dict[str, Any] = {}
    for backend, pipeline in pipelines.items():
        for name in set_names:
            spoken = few(SPOKEN_SETS[name]) if quick else SPOKEN_SETS[name]
            summary = summarise(run_set(spoken, engines, snrs, planner=pipeline))
            for engine, per_engine in summary[name].items():
                figures.setdefault(name, {}).setdefault(engine, {})[backend] = per_engine
            for key, bar in speech_bars({f"{name}/{backend}": summary[name]}, None).items():
                bars[f"spoken/{key}"] = bar
    return {"measured": True, "quick": quick, "sets": figures, "bars": bars}


def measure(pipeline: PlanningPipeline, backend: str, cases: tuple[LanguageCase, ...], layout: WorldLayout) -> dict:
    """The figures of one planner on one set. A plan the rules fallback made does not count for an LLM backend."""
    plan_case(pipeline, cases[0], layout)  # warm up (the first call loads the verb tables)
    right: Counter[str] = Counter()
    total: Counter[str] = Counter(c.kind for c in cases)
    by_topic: dict[str, list[int]] = {}
    latencies, wrong = [], []
    asked = asked_wrongly = fell_back = 0
    for case in cases:
        outcome = plan_case(pipeline, case, layout)
        latencies.append(outcome.latency_s)
        is_right = outcome.right_for(case) and _by(outcome, backend)
        fell_back += outcome.plan is not None and outcome.planner != backend
        right[case.kind] += is_right
        counts = by_topic.setdefault(f"{case.kind}: {case.topic}", [0, 0])
        counts[0] += is_right
        counts[1] += 1
        asked += outcome.question is not None
        asked_wrongly += outcome.question is not None and case.expected != CLARIFY
        if not is_right:
            wrong.append({"kind": case.kind, "text": case.text, "expected": case.expected, "got": outcome.said()})
    ms = np.asarray(latencies) * 1000.0
    return {
        "available": True,
        "cases": len(cases),
        **{
            f"{kind}_right": {"right": right[kind], "of": total[kind], "rate": _rate(right[kind], total[kind])}
            for kind in KINDS
        },
        "clarifications_asked": asked,
        "clarifications_asked_wrongly": asked_wrongly,
        "fell_back_to_rules": fell_back,
        "latency_ms": {
            "p50": round(float(np.percentile(ms, 50)), 3),
            "p99": round(float(np.percentile(ms, 99)), 3),
            "max": round(float(ms.max()), 3),
        },
        "by_topic": {topic: f"{r}/{n}" for topic, (r, n) in sorted(by_topic.items())},
        "wrong": wrong,
    }


def _by(outcome: Outcome, backend: str) -> bool:
    """Whether the backend itself gave this outcome: a plan it made, a refusal it made (it said it cannot, or none
    of its plans held in the world), not what the rules fallback did after it failed or could not be reached."""
    if backend == "rules":
        return True
    if outcome.plan is not None:
        return outcome.planner == backend
    refused = outcome.refusal or ""
    return f"{backend} says it cannot" in refused or f"{backend} gave no valid plan" in refused


def _rate(right: int, of: int) -> float | None:
    return round(right / of, 4) if of else None


def _bars(typed: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The issue's bars for the rules planner, on every set."""
    bars: dict[str, Any] = {}
    for set_name, per_backend in typed.items():
        rules = per_backend.get("rules")
        if not rules or not rules.get("available"):
            continue
        for kind, target in BARS.items():
            measured = rules[f"{kind}_right"]["rate"]
            bars[f"{set_name}_{kind}"] = {"target": target, "measured": measured, "met": measured >= target}
    return bars
