"""The planner interface: text and context in, a plan out (validated by the caller)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from robot.interface import Plan

if TYPE_CHECKING:
    from robot.planning.context import PlanningContext


class PlanningError(Exception):
    """The planner could not turn the text into a plan; the message says why, for the operator."""


class Planner(Protocol):
    name: str

    def plan(self, text: str, context: PlanningContext) -> Plan: ...
