"""What was heard, planned: a recogniser's likeliest wording, else the first of its other wordings the planner can
read. One rule for the robot (which then asks before running it) and for the speech bench (which counts it)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

from robot.planning.config import PlannerConfig
from robot.planning.context import PlanningContext
from robot.planning.pipeline import PlanningPipeline, PlanResult, build_pipeline
from robot.planning.planner import ClarificationNeeded, PlanningError
from robot.planning.world_context import WorldContext
from robot.speech.asr import ALTERNATIVES_KEPT

MAX_ALTERNATIVES = ALTERNATIVES_KEPT
MAX_WORDING_CHARS = 500


def first_readable(
    planning: PlanningPipeline, wordings: tuple[str, ...], context: PlanningContext
) -> tuple[str, PlanResult] | None:
    """The first wording that plans (one that makes the planner ask a question does not count), with its plan."""
    for wording in wordings[:MAX_ALTERNATIVES]:
        wording = wording.strip()[:MAX_WORDING_CHARS]
        if not wording:
            continue
        try:
            return wording, planning.plan(wording, context)
        except (ClarificationNeeded, PlanningError):
            continue
    return None


@dataclass(frozen=True)
class Reading:
    """How the planner reads a wording: it `plans` it, `asks` a question first (it understood enough for that), or
    leaves it `unread`; `names`: the world's names the plan's steps use, or those the question offers."""

    kind: Literal["plans", "asks", "unread"]
    names: frozenset[str] = frozenset()


UNREAD = Reading("unread")


class WorldReader:
    """How a wording reads as a command of this world, asked of the rules planner (deterministic, a few ms a
    wording, whatever planner the robot runs). A recogniser asks it to choose, among the wordings the audio
    supports, the likeliest that is a command. It does not know what the robot holds, so a wording reads when it
    plans with empty hands or with something in them ("put it on the table")."""

    def __init__(self, world: WorldContext) -> None:
        self._planning = build_pipeline(PlannerConfig(backend="rules"))
        self._contexts = [PlanningContext(replace(world, held_object=None))]
        if world.objects:
            holding = replace(world, held_object=next(iter(world.objects)))
            self._contexts.append(PlanningContext(holding))

    def read(self, wording: str) -> Reading:
        wording = wording.strip()[:MAX_WORDING_CHARS]
        reading = UNREAD
        if not wording:
            return reading
        for context in self._contexts:
            try:
                plan = self._planning.plan(wording, context).plan
                return Reading("plans", frozenset(v for step in plan.steps for v in step.args.values()))
            except ClarificationNeeded as question:
                reading = Reading("asks", frozenset(question.options))
            except PlanningError:
                continue
        return reading
