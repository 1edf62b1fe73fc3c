"""The planning front: a command in words (or the operator's own plan) becomes a checked plan for the task runner,
planned from the robot's world as it is now and the conversation so far; a failed plan is planned again from
where the robot stands, a few times per command.

Planning happens on the caller's thread, before anything changes: a bad command is refused with its reasons.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from robot.core.safety import SafetyLatch
from robot.interface import CommandReply, ExecutePlan, Level, Plan, PlanState, Refusal, RunCommand
from robot.planning.context import ConversationMemory, PlanningContext
from robot.planning.heard import first_readable
from robot.planning.pipeline import PlanningPipeline, PlanResult
from robot.planning.planner import ClarificationNeeded, PlanningError
from robot.planning.validator import validate_plan_json
from robot.planning.world_context import WorldContext
from robot.tasks.runner import OPERATOR_PLAN, Job, TaskRunner, failure_of

MAX_COMMAND_CHARS = 500


class PlanCommands:
    """`refusal`: why no plan may start now (the latch, teleop); `world`: the world as the robot knows it now."""

    def __init__(
        self,
        runner: TaskRunner,
        planning: PlanningPipeline,
        lock: threading.RLock,
        latch: SafetyLatch,
        refusal: Callable[[], CommandReply | None],
        world: Callable[[], WorldContext],
        publish: Callable[..., Any],
        max_auto_replans: int = 2,
    ) -> None:
        self._runner = runner
        self.planning = planning
        self._lock = lock
        self._latch = latch
        self._refusal = refusal
        self._world = world
        self._publish = publish
        self.max_auto_replans = max_auto_replans
        self._memory = ConversationMemory()
        self._auto_replans: dict[int, int] = {}  # command id -> automatic replans so far
        runner.listen(self)

    # ---------------------------------------------------------------------------------------------------------
    # commands

    def run_command(self, command: RunCommand) -> CommandReply:
        text = command.text.strip()
        if not text:
            return CommandReply(False, "empty command", Refusal.INVALID, ("command text is empty",))
        if len(text) > MAX_COMMAND_CHARS:
            return CommandReply(
                False, "command too long", Refusal.INVALID, (f"at most {MAX_COMMAND_CHARS} characters",)
            )
        with self._lock:
            if refusal := self._refusal():
                return refusal
        context = self._context()
        result = self._plan(text, context)
        if isinstance(result, CommandReply) and result.clarify is None and command.alternatives:
            asked = self._ask_about_alternative(text, command.alternatives, context)
            if asked is not None:
                return asked
        if isinstance(result, CommandReply):
            self._memory.add(text)
            self._memory.update_last(outcome=f"refused: {result.message}")
            return result
        return self._runner.enqueue(text, result.plan, new_command=True, planned=result)

    def _ask_about_alternative(
        self, text: str, alternatives: tuple[str, ...], context: PlanningContext
    ) -> CommandReply | None:
        """`text` could not be planned: the plan of the first readable other wording the recogniser heard, waiting
        for the operator's approval ("did you mean ...?"); None when none is readable."""
        heard = first_readable(self.planning, alternatives, context)
        if heard is None:
            return None
        wording, planned = heard
        self._publish(
            "plan/heard_as",
            f"could not plan {text!r}; planned what was heard next likeliest, {wording!r}: it awaits approval",
            Level.OK,
            text=text,
            heard_as=wording,
        )
        reply = self._runner.enqueue(wording, planned.plan, new_command=True, planned=planned, ask=True)
        if not reply.accepted:
            return reply
        return replace(reply, message=f'did you mean "{wording}"? Approve its plan to run it ({reply.message})')

    def execute_plan(self, command: ExecutePlan) -> CommandReply:
        with self._lock:
            if refusal := self._refusal():
                return refusal
        checked, errors = validate_plan_json(command.plan_json, self._world())
        if checked is None:
            return CommandReply(False, "invalid plan", Refusal.INVALID, tuple(errors))
        backend = self.planning.backend
        if command.command_id is not None:  # the operator's edit of a command's plan: its next revision
            last = self._runner.last_command
            if last is None or last[0] != command.command_id:
                current = f"the current one is {last[0]}" if last else "there is none"
                return CommandReply(
                    False,
                    f"command {command.command_id} is not the current command ({current})",
                    Refusal.INVALID,
                    ("stale command id",),
                )
            return self._runner.enqueue(
                last[1], checked, new_command=False, command_id=last[0], approved=True, backend=backend
            )
        return self._runner.enqueue(
            command.text or OPERATOR_PLAN, checked, new_command=True, approved=True, backend=backend
        )

    def replan(self) -> CommandReply:
        """The operator's replan: the current command planned again from the robot's state now."""
        with self._lock:
            if refusal := self._refusal():
                return refusal
            last = self._runner.last_command
            job = self._runner.latest_job()
        if last is None:
            return CommandReply(False, "no command to replan", Refusal.NOTHING_TO_REPLAN)
        command_id, text = last
        failure, done = failure_of(job) if job is not None and job.status.command_id == command_id else (None, ())
        result = self._plan(text, self._context(failure, done))
        if isinstance(result, CommandReply):
            return result
        return self._runner.enqueue(text, result.plan, new_command=False, command_id=command_id, planned=result)

    def _context(self, failure: str | None = None, done: tuple[str, ...] = ()) -> PlanningContext:
        return PlanningContext(self._world(), self._memory.turns(), failure, done)

    def _plan(self, text: str, context: PlanningContext) -> PlanResult | CommandReply:
        """Plan `text` with the configured planner (falling back to rules); a refusal when no plan could be made."""
        try:
            result = self.planning.plan(text, context)
        except ClarificationNeeded as exc:
            asked = f"asked about {text!r}: {exc.question}"
            self._publish("plan/clarify", asked, Level.OK, text=text, question=exc.question, options=list(exc.options))
            return CommandReply(False, exc.question, Refusal.INVALID, (exc.question,), clarify=exc.question)
        except PlanningError as exc:
            self._publish(
                "plan/rejected",
                f"could not plan {text!r}: {exc}",
                Level.WARN,
                text=text,
                backend=self.planning.backend,
            )
            return CommandReply(False, str(exc), Refusal.INVALID, (str(exc),))
        if result.notes:
            kind = "plan/fallback" if result.planner != result.backend else "plan/repaired"
            message = f"{result.planner} planned {text!r}: " + "; ".join(result.notes)
            self._publish(
                kind,
                message,
                Level.WARN,
                text=text,
                planner=result.planner,
                backend=result.backend,
                notes=list(result.notes),
            )
        return result

    # ---------------------------------------------------------------------------------------------------------
    # what the runner tells

    def queued(self, text: str, plan: Plan, new_command: bool) -> None:
        if new_command:
            self._memory.add(text)
        self._memory.update_last(plan=plan, outcome="running")

    def finished(self, job: Job, result: PlanState, failure: str | None) -> None:
        last = self._runner.last_command
        if last is not None and last[0] == job.status.command_id:
            self._memory.update_last(outcome=result.value + (f": {failure}" if failure else ""))

    def replans_left(self, command_id: int) -> bool:
        return self._auto_replans.get(command_id, 0) < self.max_auto_replans

    def replan_after(self, job: Job) -> bool:
        """After a failed step: plan the command again from where the robot is, up to `max_auto_replans` times
        per command. Not after a fall or an e-stop (the robot must be seen to first), nor for an operator's plan."""
        command_id = job.status.command_id
        with self._lock:
            if self._latch.fallen or self._latch.latched or self._runner.stopping or job.fault is not None:
                return False
            if self._runner.last_command != (command_id, job.status.command_text) or self._runner.newer_queued():
                return False  # a newer command has come in
            used = self._auto_replans.get(command_id, 0)
            if used >= self.max_auto_replans or job.status.command_text == OPERATOR_PLAN or _behaviour(job.plan):
                return False
            self._auto_replans[command_id] = used + 1
        failure, done = failure_of(job)
        result = self._plan(job.status.command_text, self._context(failure, done))
        if isinstance(result, CommandReply):
            return False
        self._publish(
            "plan/replanning",
            f"replanning after: {failure} (automatic replan {used + 1} of {self.max_auto_replans})",
            Level.WARN,
            command_id=command_id,
            failure=failure,
        )
        reply = self._runner.enqueue(
            job.status.command_text, result.plan, new_command=False, command_id=command_id, planned=result
        )
        return reply.accepted


def _behaviour(plan: Plan) -> bool:
    """A behaviour's plan (its one step runs the behaviour): not planned from text, so never replanned."""
    return any(step.action == "behaviour" for step in plan.steps)
