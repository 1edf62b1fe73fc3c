"""Which planner plans, and what happens when it cannot: the configured backend first, every plan validated, and
the rules planner as the fallback, with the reasons kept for the operator."""

from __future__ import annotations

import time
from dataclasses import dataclass

from robot.interface import Plan
from robot.planning.config import BACKENDS, PlannerConfig
from robot.planning.context import PlanningContext
from robot.planning.planner import ClarificationNeeded, Planner, PlanningError
from robot.planning.rules import RulesPlanner
from robot.planning.validator import validate_plan


@dataclass(frozen=True)
class PlanResult:
    plan: Plan
    planner: str  # who made this plan: "openai", "local" or "rules"
    backend: str  # the configured backend
    notes: tuple[str, ...] = ()  # why the configured backend's plan was repaired or not used
    latency_s: float = 0.0
    attempts: int = 1  # exchanges with the configured backend's model (1 + repairs)


class PlanningPipeline:
    """Plans with `primary` and checks the plan against the world; on any failure of a non-rules primary (no
    answer, timeout, HTTP error, invalid after repair) the rules planner plans instead, and the result says why."""

    def __init__(self, primary: Planner | None, backend: str, fallback: Planner | None, unavailable: str = "") -> None:
        self.primary = primary
        self.backend = backend
        self.fallback = fallback
        self.unavailable = unavailable  # why the configured backend could not be built

    def describe(self) -> str:
        if self.primary is None:
            return f"{self.backend} (unavailable: {self.unavailable})"
        describe = getattr(self.primary, "describe", None)
        return f"{self.backend}: {describe()}" if describe else self.backend

    def plan(self, text: str, context: PlanningContext) -> PlanResult:
        started = time.perf_counter()
        notes: list[str] = []
        attempts = 0
        if self.primary is None:
            notes.append(f"{self.backend} backend unavailable: {self.unavailable}")
        else:
            try:
                plan = self._checked(self.primary, text, context)
            except PlanningError as exc:
                if self.fallback is None:
                    raise
                notes.append(f"{self.backend}: {exc}")
                plan = None
            attempts = len(getattr(self.primary, "last_attempts", ())) or 1
            if plan is not None:
                if attempts > 1:
                    notes.append(f"{self.backend}: plan repaired after {attempts - 1} invalid answer(s)")
                return PlanResult(
                    plan, self.primary.name, self.backend, tuple(notes), time.perf_counter() - started, attempts
                )
        if self.fallback is None:
            raise PlanningError("; ".join(notes))
        try:
            plan = self._checked(self.fallback, text, context)
        except ClarificationNeeded:
            raise  # a question for the operator, not a failure to explain
        except PlanningError as exc:
            raise PlanningError("; ".join([*notes, f"{self.fallback.name} fallback: {exc}"])) from exc
        notes.append(f"planned by {self.fallback.name} instead")
        return PlanResult(plan, self.fallback.name, self.backend, tuple(notes), time.perf_counter() - started, attempts)

    @staticmethod
    def _checked(planner: Planner, text: str, context: PlanningContext) -> Plan:
        plan = planner.plan(text, context)
        checked, errors = validate_plan(plan, context.world)
        if checked is None:
            raise PlanningError(f"invalid plan: {'; '.join(errors)}")
        return checked


def build_pipeline(config: PlannerConfig) -> PlanningPipeline:
    """The pipeline for a configuration. A backend that cannot be built (no llama-cpp-python, no model file)
    leaves the rules planner planning, and every plan result says why."""
    rules = RulesPlanner()
    if config.backend == "rules":
        return PlanningPipeline(rules, "rules", fallback=None)
    fallback = rules if config.fallback_to_rules else None
    try:
        primary = build_llm_planner(config)
    except PlanningError as exc:
        return PlanningPipeline(None, config.backend, fallback, unavailable=str(exc))
    return PlanningPipeline(primary, config.backend, fallback)


def build_llm_planner(config: PlannerConfig) -> Planner:
    from robot.planning.llm import LLMPlanner

    if config.backend == "openai":
        from robot.planning.openai_chat import OpenAIChat

        try:
            model = OpenAIChat(
                config.openai_base_url,
                config.openai_model,
                config.openai_api_key,
                config.openai_timeout_s,
                config.openai_response_format,
            )
        except ImportError as exc:
            raise PlanningError("the openai backend needs the openai package") from exc
        return LLMPlanner(model, config.max_repairs)
    if config.backend == "local":
        from robot.planning.local_chat import LocalChat

        chat = LocalChat(
            config.local_model_path,
            n_threads=config.local_threads,
            timeout_s=config.local_timeout_s,
            chat_format=config.local_chat_format,
        )
        return LLMPlanner(chat, config.max_repairs)
    raise PlanningError(f"unknown planner backend {config.backend!r} (known: {', '.join(BACKENDS)})")
