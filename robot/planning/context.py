"""What a planner is told besides the command: the world as believed, the recent conversation, and, when it is
asked to replan, what went wrong."""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, replace

from robot.interface import Plan
from robot.planning.world_context import WorldContext


@dataclass(frozen=True)
class Turn:
    """One command of the conversation: what was asked, what was planned, and how it ended."""

    command: str
    plan: Plan | None = None
    outcome: str = "pending"  # pending | running | succeeded | failed: <reason> | cancelled | refused: <reason>


@dataclass(frozen=True)
class PlanningContext:
    world: WorldContext
    history: tuple[Turn, ...] = ()  # oldest first, the current command not included
    # When replanning: the failed plan's outcome ("step 3 pick_object failed: grasp slipped") and the steps that
    # had already succeeded, so a planner can carry on from where the robot is instead of starting over.
    failure: str | None = None
    done: tuple[str, ...] = ()


class ConversationMemory:
    """The last few turns, for planners that read context (LLMs): bounded, thread-safe, newest last."""

    def __init__(self, max_turns: int = 6) -> None:
        self._turns: deque[Turn] = deque(maxlen=max_turns)
        self._lock = threading.Lock()

    def add(self, command: str) -> None:
        with self._lock:
            self._turns.append(Turn(command))

    def update_last(self, plan: Plan | None = None, outcome: str | None = None) -> None:
        """Record the plan made for, or the outcome of, the newest command."""
        with self._lock:
            if not self._turns:
                return
            last = self._turns[-1]
            self._turns[-1] = replace(
                last, plan=plan if plan is not None else last.plan, outcome=outcome if outcome else last.outcome
            )

    def turns(self, exclude_last: bool = False) -> tuple[Turn, ...]:
        with self._lock:
            turns = tuple(self._turns)
        return turns[:-1] if exclude_last and turns else turns
