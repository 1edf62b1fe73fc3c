"""Commands in everyday wording with what each must give, for `humanoid bench language` and the tests.

Every case is asked in the default world (seed 0: the mug, the bottle and the apple on the kitchen counter; the
living-room table and the charging dock in the living room) and is labelled with one of:

- a plan (the seed's list of flat actions, as in `planner_cases`): right when the planner gives exactly it;
- `REFUSE`: right when no plan is made and no question is asked (something not in the world, or not an ability);
- `CLARIFY`: right when the planner asks one question instead of planning (two readings are truly close).

How a sentence of several steps is labelled (`seq`): the plans of its steps in the order they are to be done; the
confirmation a planner says at the end of a step (`say "*"`) is left out when another step follows; a `say` the
person asked for stays; a step the same as the one just before it (walking again to where the robot already
went) is left out.

Kinds, reported apart: `everyday` (the wording people use), `paraphrase` (close paraphrases of the README's
examples), `out_of_world` (must be refused), `clarify` (must be asked about).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Literal

from harness.planner_cases import (
    APPLE,
    BOTTLE,
    COUNTER,
    DOCK,
    HOME,
    LOOK_AND_TELL,
    MUG,
    STOP,
    TABLE,
    Seed,
    carry,
    context_for,
    fetch,
    find,
    go,
    plan_matches,
    seq,
)
from robot.model.world import WorldLayout
from robot.planning.pipeline import PlanningPipeline
from robot.planning.planner import ClarificationNeeded, PlanningError

__all__ = [
    "APPLE",
    "BOTTLE",
    "CLARIFY",
    "COUNTER",
    "DOCK",
    "HOME",
    "LOOK",
    "LOOK_AND_TELL",
    "MUG",
    "REFUSE",
    "STOP",
    "TABLE",
    "Kind",
    "LanguageCase",
    "Seed",
    "carry",
    "fetch",
    "find",
    "go",
    "say",
    "seq",
    "wait",
]

REFUSE = "refuse"
CLARIFY = "clarify"
Kind = Literal["everyday", "paraphrase", "out_of_world", "clarify"]
KINDS: tuple[Kind, ...] = ("everyday", "paraphrase", "out_of_world", "clarify")
LOOK: Seed = [{"action": "look_around"}]


@dataclass(frozen=True)
class LanguageCase:
    kind: Kind
    topic: str  # what the case tries: politeness, sequence, near-miss name, unknown object, ...
    text: str
    expected: Seed | str  # a plan, REFUSE or CLARIFY
    held: str | None = None  # the object in the robot's hand when the command comes
    history: tuple[tuple[str, Seed], ...] = field(default=())  # earlier commands with their plans

    def __post_init__(self) -> None:
        if isinstance(self.expected, str) and self.expected not in (REFUSE, CLARIFY):
            raise ValueError(f"expected is a plan, {REFUSE!r} or {CLARIFY!r}, not {self.expected!r}")
        if self.kind == "out_of_world" and self.expected != REFUSE:
            raise ValueError(f"an out-of-world case must be refused: {self.text!r}")
        if self.kind == "clarify" and self.expected != CLARIFY:
            raise ValueError(f"a clarify case must expect a question: {self.text!r}")


def say(text: str) -> Seed:
    return [{"action": "say", "text": text}]


def wait(seconds: str) -> Seed:
    return [{"action": "wait", "seconds": seconds}]


# the bars, on every set
BARS = {"everyday": 0.94, "paraphrase": 0.95, "out_of_world": 1.0}


@dataclass(frozen=True)
class Outcome:
    """What a planner made of one command: a plan (flat actions), a question, or a refusal, and who planned it."""

    plan: list[dict[str, str]] | None = None
    question: str | None = None
    refusal: str | None = None
    planner: str = ""
    latency_s: float = 0.0

    def right_for(self, case: LanguageCase) -> bool:
        if case.expected == REFUSE:
            return self.refusal is not None
        if case.expected == CLARIFY:
            return self.question is not None
        return self.plan is not None and plan_matches(case.expected, self.plan)  # type: ignore[arg-type]

    def said(self) -> Any:
        if self.plan is not None:
            return self.plan
        return {"clarify": self.question} if self.question is not None else {"refused": self.refusal}


def plan_case(pipeline: PlanningPipeline, case: LanguageCase, layout: WorldLayout) -> Outcome:
    context = context_for(case, layout)
    started = time.perf_counter()
    try:
        result = pipeline.plan(case.text, context)
    except ClarificationNeeded as exc:
        return Outcome(question=exc.question, latency_s=time.perf_counter() - started)
    except PlanningError as exc:
        return Outcome(refusal=str(exc), latency_s=time.perf_counter() - started)
    return Outcome(plan=result.plan.to_seed_list(), planner=result.planner, latency_s=time.perf_counter() - started)
