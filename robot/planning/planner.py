"""The planner interface: text and context in, a plan out (validated by the caller)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from robot.interface import Plan

if TYPE_CHECKING:
    from robot.planning.context import PlanningContext


class PlanningError(Exception):
    """The planner could not turn the text into a plan; the message says why, for the operator."""


class ClarificationNeeded(PlanningError):
    """Two readings of the command are close: the robot asks this one short question instead of acting."""

    def __init__(self, question: str, options: tuple[str, ...] = ()) -> None:
        super().__init__(question)
        self.question = question
        self.options = options  # the readings it hesitates between, e.g. ("red mug", "blue bottle")


class Planner(Protocol):
    name: str

    def plan(self, text: str, context: PlanningContext) -> Plan: ...
