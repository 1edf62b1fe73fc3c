"""The task runner: plans as jobs, one at a time on the "robot-tasks" thread, with the operator's controls (approve,
pause, resume, cancel), each step's status as it goes, and a listener told when a plan is queued and when it ends
(the planning front keeps the conversation and replans after a failed step).

A newer plan supersedes whatever ran or waited; an e-stop cancels them all, and a plan that was queued just as it
latched is ended visibly, never started.
"""

from __future__ import annotations

import contextlib
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, Protocol

from robot.core.safety import SafetyLatch
from robot.interface import (
    ApprovePlan,
    CommandReply,
    Level,
    Plan,
    PlanState,
    PlanStatus,
    Refusal,
    StepState,
    StepStatus,
)
from robot.planning.executor import Cancelled, ExecutionContext, PlanExecutor
from robot.planning.pipeline import PlanResult

OPERATOR_PLAN = "(operator plan)"


@dataclass
class Job:
    status: PlanStatus
    plan: Plan
    cancel: threading.Event
    fault: str | None = None  # set with `cancel` when a fault (a fall) stopped the plan
    pausing: bool = False  # set with `cancel` when the operator paused the plan
    start: int = 0  # the step to start from (a resumed plan goes on from its paused step)


def failure_of(job: Job) -> tuple[str | None, tuple[str, ...]]:
    """A failed plan's first failed step and reason, and the steps done before it, for a replanner."""
    steps = job.status.steps
    failed = next((s for s in steps if s.state == StepState.FAILED), None)
    if failed is None:
        return None, ()
    done = tuple(f"{s.action}({', '.join(s.args.values())})" for s in steps if s.state == StepState.SUCCEEDED)
    return f"step {failed.index + 1} {failed.action} failed: {failed.detail}", done


def step_summary(steps: tuple[StepStatus, ...]) -> list[dict[str, str]]:
    return [{"action": s.action, "state": s.state.value, "detail": s.detail} for s in steps]


class RunnerListener(Protocol):
    """Told what happens to plans (the planning front: the conversation, automatic replans)."""

    def queued(self, text: str, plan: Plan, new_command: bool) -> None:
        """Under the lock, as a plan is accepted (before it can run)."""

    def finished(self, job: Job, result: PlanState, failure: str | None) -> None: ...

    def replans_left(self, command_id: int) -> bool: ...

    def replan_after(self, job: Job) -> bool:
        """After a failed plan: plan its command again; whether a new plan was queued."""


class TaskRunner:
    """`refusal`: why no plan may start now (the latch, teleop); `clock`: simulated time; `settle`: block (with a
    cancel event) until the body is at rest, its arm included, before a plan ends; `stand`: a new plan starts
    from the standing posture; `held_object`: what the hand holds, for the steps."""

    def __init__(
        self,
        executor: PlanExecutor,
        lock: threading.RLock,
        latch: SafetyLatch,
        refusal: Callable[[], CommandReply | None],
        publish: Callable[..., Any],
        clock: Callable[[], float],
        settle: Callable[[threading.Event], None],
        stand: Callable[[], None],
        held_object: Callable[[], str | None],
        approve_plans: bool = False,
    ) -> None:
        self._executor = executor
        self._lock = lock
        self._latch = latch
        self._refusal = refusal
        self._publish = publish
        self._clock = clock
        self._settle = settle
        self._stand = stand
        self._held_object = held_object
        self._listener: RunnerListener | None = None
        self._approval_required = approve_plans
        self._jobs: queue.Queue[Job | None] = queue.Queue()
        self._current: Job | None = None
        self._finished: Job | None = None  # the last plan that ran, shown until the next one starts
        self._held: Job | None = None  # a plan awaiting approval, or a paused one
        self._last_command: tuple[int, str] | None = None  # (command_id, text) of the command being served
        self._next_command_id = 1
        self._next_plan_id = 1
        self._revisions: dict[int, int] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def listen(self, listener: RunnerListener) -> None:
        self._listener = listener

    # ---------------------------------------------------------------------------------------------------------
    # lifecycle

    def start(self) -> None:
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="robot-tasks", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        with self._lock:
            if self._current:
                self._current.cancel.set()
        self._jobs.put(None)
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self._thread = None

    def is_alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    # ---------------------------------------------------------------------------------------------------------
    # what is running

    @property
    def running(self) -> bool:
        return self._current is not None

    @property
    def busy(self) -> bool:
        """A plan runs or waits in the queue (teleop and postures must wait)."""
        return self._current is not None or not self._jobs.empty()

    @property
    def approval_required(self) -> bool:
        return self._approval_required

    @property
    def last_command(self) -> tuple[int, str] | None:
        return self._last_command

    def shown(self) -> PlanStatus | None:
        job = self._current or self._held or self._finished
        return job.status if job else None

    def latest_job(self) -> Job | None:
        """The running plan, else the last one that ran."""
        return self._current or self._finished

    def newer_queued(self) -> bool:
        return not self._jobs.empty()

    def fault(self, reason: str) -> None:
        """A fault (a fall) stops the running plan: its step fails with `reason`."""
        with self._lock:
            if self._current:
                self._current.fault = reason
                self._current.cancel.set()

    # ---------------------------------------------------------------------------------------------------------
    # the operator's controls

    def enqueue(
        self,
        text: str,
        plan: Plan,
        new_command: bool,
        command_id: int | None = None,
        planned: PlanResult | None = None,
        approved: bool = False,
        backend: str = "",
        ask: bool = False,
    ) -> CommandReply:
        """Start a plan (a new command's, or a new revision of the current one), superseding whatever ran or
        waited; with approval required, a planner's plan waits for the operator instead (and with `ask`, whatever
        the setting: a plan of a wording the operator did not give)."""
        with self._lock:
            # an e-stop (or teleop) may have come in while planning
            if refusal := self._refusal():
                return refusal
            if new_command:
                command_id = self._next_command_id
                self._next_command_id += 1
                self._publish("command/received", f"command: {text}", command_id=command_id, text=text)
            if self._listener is not None:
                self._listener.queued(text, plan, new_command)
            assert command_id is not None
            revision = self._revisions.get(command_id, 0) + 1
            self._revisions[command_id] = revision
            plan_id = self._next_plan_id
            self._next_plan_id += 1
            self._last_command = (command_id, text)
            if self._current:
                self._current.cancel.set()  # the newest command or plan revision preempts the running one
            self.drain("superseded by a newer plan")
            awaits = (self._approval_required and not approved) or ask
            status = PlanStatus(
                plan_id=plan_id,
                command_id=command_id,
                command_text=text,
                revision=revision,
                state=PlanState.AWAITING_APPROVAL if awaits else PlanState.RUNNING,
                steps=tuple(StepStatus(i, s.action, dict(s.args)) for i, s in enumerate(plan.steps)),
            )
            self._publish(
                "plan/created",
                f"plan {plan_id} (revision {revision}): " + ", ".join(s.action for s in plan.steps),
                plan_id=plan_id,
                command_id=command_id,
                revision=revision,
                text=text,
                plan=plan.to_dict(),
                planner=planned.planner if planned else "operator",
                backend=planned.backend if planned else backend,
                notes=list(planned.notes) if planned else [],
                planning_ms=round(planned.latency_s * 1000, 1) if planned else 0.0,
            )
            job = Job(status, plan, threading.Event())
            if awaits:
                self._held = job
            else:
                self._jobs.put(job)
        if awaits:
            self._publish(
                "plan/awaiting_approval",
                f"plan {plan_id} awaits the operator's approval",
                plan_id=plan_id,
                command_id=command_id,
            )
        how = f" (planned by {planned.planner}: {'; '.join(planned.notes)})" if planned and planned.notes else ""
        queued = "awaits approval" if awaits else "queued"
        return CommandReply(True, f"plan {plan_id} {queued}{how}", command_id=command_id, plan=plan)

    def _held_in(self, state: PlanState, missing: str) -> Job | CommandReply:
        """The held plan if it is in `state` and motion is allowed, else the refusal; under the lock."""
        if refusal := self._refusal():
            return refusal
        job = self._held
        if job is None or job.status.state != state:
            return CommandReply(False, missing, Refusal.NOTHING_TO_DO)
        return job

    def approve(self, command: ApprovePlan) -> CommandReply:
        with self._lock:
            job = self._held_in(PlanState.AWAITING_APPROVAL, "no plan awaits approval")
            if isinstance(job, CommandReply):
                return job
            if command.plan_id is not None and command.plan_id != job.status.plan_id:
                return CommandReply(
                    False,
                    f"plan {command.plan_id} no longer awaits approval (plan {job.status.plan_id} does)",
                    Refusal.INVALID,
                    ("stale plan id",),
                )
            self._held = None
            job.status = replace(job.status, state=PlanState.RUNNING)
            self._jobs.put(job)
        self._publish("plan/approved", f"plan {job.status.plan_id} approved", plan_id=job.status.plan_id)
        return CommandReply(
            True, f"plan {job.status.plan_id} approved", command_id=job.status.command_id, plan=job.plan
        )

    def pause(self) -> CommandReply:
        with self._lock:
            job = self._current
            if job is None:
                return CommandReply(False, "no plan is running", Refusal.NOTHING_TO_DO)
            job.pausing = True
            job.cancel.set()
        return CommandReply(True, f"pausing plan {job.status.plan_id}")

    def resume(self) -> CommandReply:
        with self._lock:
            job = self._held_in(PlanState.PAUSED, "no plan is paused")
            if isinstance(job, CommandReply):
                return job
            start = next(s.index for s in job.status.steps if s.state == StepState.PAUSED)
            steps = tuple(
                replace(s, state=StepState.PENDING, detail="") if s.index == start else s for s in job.status.steps
            )
            resumed = Job(
                replace(job.status, state=PlanState.RUNNING, steps=steps), job.plan, threading.Event(), start=start
            )
            self._held = None
            self._jobs.put(resumed)
        self._publish(
            "plan/resumed", f"plan {job.status.plan_id} resumed at step {start + 1}", plan_id=job.status.plan_id
        )
        return CommandReply(
            True, f"plan {job.status.plan_id} resumed at step {start + 1}", command_id=job.status.command_id
        )

    def set_approval(self, required: bool) -> CommandReply:
        with self._lock:
            self._approval_required = required
        self._publish(
            "plan/approval", "plans wait for approval" if required else "plans run when planned", required=required
        )
        return CommandReply(True, "plans now wait for approval" if required else "plans now run when planned")

    def cancel(self, reason: str) -> CommandReply:
        """Cancel the running plan and every one that has not started."""
        with self._lock:
            job = self._current
            held = self._held
            if job:
                job.cancel.set()
            self.drain(reason)
        return CommandReply(True, "plan cancelled" if job or held else "no plan running")

    def drain(self, reason: str) -> None:
        """Cancel every plan that has not started (queued, awaiting approval, paused)."""
        with self._lock:
            held, self._held = self._held, None
            if held is not None:
                self._end_unstarted(held, reason)
            while True:
                try:
                    job = self._jobs.get_nowait()
                except queue.Empty:
                    return
                if job is None:
                    self._jobs.put(None)
                    return
                self._end_unstarted(job, reason)

    def _end_unstarted(self, job: Job, reason: str) -> None:
        job.cancel.set()
        steps = tuple(
            s
            if s.state in (StepState.SUCCEEDED, StepState.FAILED)
            else replace(s, state=StepState.CANCELLED, detail=reason)
            for s in job.status.steps
        )
        job.status = replace(job.status, state=PlanState.CANCELLED, steps=steps)
        self._finished = job
        self._publish(
            "plan/finished",
            f"plan {job.status.plan_id} {reason}",
            Level.WARN,
            plan_id=job.status.plan_id,
            state=PlanState.CANCELLED.value,
            steps=step_summary(steps),
        )

    # ---------------------------------------------------------------------------------------------------------
    # the task thread

    def wait_sim(self, seconds: float, cancel: threading.Event) -> None:
        """Block until `seconds` of simulated time have passed; raises `Cancelled` when the plan is cancelled."""
        target = self._clock() + seconds
        while self._clock() < target:
            if cancel.is_set():
                raise Cancelled()
            if self._stop.is_set():
                raise Cancelled()
            cancel.wait(0.002)

    def _run(self) -> None:
        while not self._stop.is_set():
            job = self._jobs.get()
            if job is None:
                return
            with self._lock:
                if job.cancel.is_set() or self._latch.latched:
                    # an e-stop may have drained the queue just after this job left it: end it here, visibly
                    if job.status.state != PlanState.CANCELLED:
                        self._end_unstarted(job, "cancelled by e-stop" if self._latch.latched else "cancelled")
                    continue
                self._current = job
                self._stand()  # a new plan starts from the standing posture (a move: only after a command)
            result = self._execute(job)
            self._finish(job, result)

    def _execute(self, job: Job) -> PlanState:
        context = ExecutionContext(
            cancel=job.cancel,
            say=lambda text: self._publish("speech/say", text, text=text),
            wait_sim=lambda seconds, cancel=job.cancel: self.wait_sim(seconds, cancel),
            held_object=self._held_object,
            fault=lambda j=job: j.fault,
            pausing=lambda j=job: j.pausing,
        )
        return self._executor.run(
            job.plan, context, lambda i, st, d, j=job: self._on_step(j, i, st, d), start=job.start
        )

    def _finish(self, job: Job, result: PlanState) -> None:
        with contextlib.suppress(Cancelled):  # a plan ends with the robot at rest, its arm included
            self._settle(job.cancel)
        failure, _ = failure_of(job)
        listener = self._listener
        with self._lock:
            if result == PlanState.PAUSED and (self._latch.latched or self._latch.fallen):
                # an e-stop or a fall came with the pause: nothing is left to resume
                result = PlanState.CANCELLED
                job.status = replace(
                    job.status,
                    steps=tuple(
                        replace(s, state=StepState.CANCELLED, detail="cancelled by e-stop")
                        if s.state in (StepState.PAUSED, StepState.PENDING)
                        else s
                        for s in job.status.steps
                    ),
                )
            # the state says a replan is coming, so nobody waiting for the command's end stops here
            replans_left = listener is not None and listener.replans_left(job.status.command_id)
            job.status = replace(job.status, state=result, replanning=result == PlanState.FAILED and replans_left)
            self._current = None
            self._finished = job
            if result == PlanState.PAUSED:
                self._held = job
        if listener is not None:
            listener.finished(job, result, failure)
        level = Level.OK if result == PlanState.SUCCEEDED else Level.WARN
        failed = [s for s in job.status.steps if s.state == StepState.FAILED]
        message = f"plan {job.status.plan_id} {result.value}" + (f": {failed[0].detail}" if failed else "")
        self._publish(
            "plan/finished",
            message,
            level,
            plan_id=job.status.plan_id,
            state=result.value,
            steps=step_summary(job.status.steps),
        )
        if job.status.replanning and not (listener is not None and listener.replan_after(job)):
            with self._lock:
                job.status = replace(job.status, replanning=False)

    def _on_step(self, job: Job, index: int, state: StepState, detail: str) -> None:
        now = self._clock()
        with self._lock:
            old = job.status.steps[index]
            new = replace(
                old,
                state=state,
                detail=detail,
                sim_start_s=now if state == StepState.RUNNING else old.sim_start_s,
                sim_end_s=now if state != StepState.RUNNING else None,
            )
            steps = list(job.status.steps)
            steps[index] = new
            job.status = replace(job.status, steps=tuple(steps))
        level = Level.WARN if state == StepState.FAILED else Level.OK
        self._publish(
            "plan/step",
            f"step {index + 1} {new.action}: {state.value}" + (f" ({detail})" if detail else ""),
            level,
            plan_id=job.status.plan_id,
            index=index,
            action=new.action,
            args=new.args,
            state=state.value,
            detail=detail,
            sim_start_s=new.sim_start_s,
            sim_end_s=new.sim_end_s,
        )
