"""The planner interface: text and world context in, a plan out (validated by the caller)."""

from __future__ import annotations

from typing import Protocol

from robot.interface import Plan
from robot.planning.world_context import WorldContext


class PlanningError(Exception):
    """The planner could not turn the text into a plan; the message says why, for the operator."""


class Planner(Protocol):
    name: str

    def plan(self, text: str, world: WorldContext) -> Plan: ...
