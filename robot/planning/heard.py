"""What was heard, planned: a recogniser's likeliest wording, else the first of its other wordings the planner can
read. One rule for the robot (which then asks before running it) and for the speech bench (which counts it)."""

from __future__ import annotations

from robot.planning.context import PlanningContext
from robot.planning.pipeline import PlanningPipeline, PlanResult
from robot.planning.planner import ClarificationNeeded, PlanningError
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
