"""Runs behaviours as jobs of the task runner, so a behaviour is to the robot what a plan is: it excludes plans
and teleop (refused with the reason), an e-stop cancels it and holds, a fall fails it, the operator pauses and
resumes it with the plan controls or these.

A behaviour is queued as a one-step plan whose step, `behaviour`, runs its state machine: each state's step in
its own thread, watched from the task thread, so that user code is contained: an exception, or a step that
overruns its timeout, ends the behaviour with the reason, and the robot is left standing with its arm stowed.
A paused behaviour keeps its state; on resume, the step of that state runs again.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from robot.behaviours.api import BadParameter, Behaviour, BehaviourFailed
from robot.behaviours.intents import Intent, control_word, read_intent
from robot.behaviours.registry import Registry
from robot.behaviours.robot_view import BehaviourRobot
from robot.control.head import DEFAULT_TILT
from robot.control.locomotion import Velocity
from robot.interface import (
    BehaviourInfo,
    BehaviourState,
    BehaviourStatus,
    CommandReply,
    Level,
    PauseBehaviour,
    Plan,
    PlanState,
    Refusal,
    RunCommand,
    StartBehaviour,
    Step,
    StopBehaviour,
)
from robot.model.world import WorldLayout
from robot.planning.executor import Cancelled, Capability, ExecutionContext, StepFailed
from robot.planning.world_context import WorldContext
from robot.skills.body import BodyParts
from robot.skills.catalogue import Skills
from robot.tasks.runner import TaskRunner

BEHAVIOUR_ACTION = "behaviour"  # the one step of the plan a behaviour runs as
MAX_FEEDBACK_LINES = 200  # kept in the status (the session keeps them all, as events)
STEP_EXIT_WALL_S = 5.0  # how long a stopped step's thread may take to notice it was stopped
SETTLE_SIM_S = 10.0  # making the robot safe after a behaviour may take this long


@dataclass
class Run:
    """One behaviour run: the instance (its own state between steps) and what the operator sees of it."""

    run_id: int
    behaviour: Behaviour
    params: dict[str, Any]
    machine_state: str
    started_sim_s: float
    state: BehaviourState = BehaviourState.QUEUED
    progress: float = 0.0
    feedback: list[str] = field(default_factory=list)
    reason: str = ""
    command_id: int | None = None
    ended_sim_s: float | None = None
    stop_reason: str | None = None  # set when the operator or the e-stop stopped it
    pause_reason: str = ""
    inbox: list[str] = field(default_factory=list)  # commands said to a behaviour that listens, oldest first

    @property
    def name(self) -> str:
        return self.behaviour.name

    def status(self) -> BehaviourStatus:
        return BehaviourStatus(
            run_id=self.run_id,
            name=self.name,
            params=dict(self.params),
            state=self.state,
            machine_state=self.machine_state,
            progress=self.progress,
            feedback=tuple(self.feedback[-MAX_FEEDBACK_LINES:]),
            reason=self.reason,
            command_id=self.command_id,
            started_sim_s=self.started_sim_s,
            ended_sim_s=self.ended_sim_s,
        )


class RunReporter:
    """A run's reports as the behaviour's code makes them: into its status, and out as events."""

    def __init__(self, run: Run, lock: threading.RLock, publish: Callable[..., Any]) -> None:
        self._run = run
        self._lock = lock
        self._publish = publish

    def feedback(self, line: str) -> None:
        with self._lock:
            self._run.feedback.append(line)
        self._publish("behaviour/feedback", line, run_id=self._run.run_id, name=self._run.name, line=line)

    def progress(self, fraction: float) -> None:
        with self._lock:
            self._run.progress = fraction

    def snapshot(self, message: str, data: dict[str, Any]) -> None:
        with self._lock:
            self._run.feedback.append(message)
        self._publish("behaviour/snapshot", message, run_id=self._run.run_id, name=self._run.name, **data)

    def next_command(self) -> str | None:
        with self._lock:
            return self._run.inbox.pop(0) if self._run.inbox else None


@dataclass(frozen=True)
class BehaviourParts:
    """What behaviours are built on: the skills and the parts they use, the world, and the task runner."""

    parts: BodyParts
    skills: Skills
    capabilities: dict[str, Capability]
    layout: WorldLayout
    world: Callable[[], WorldContext]
    tasks: TaskRunner
    motion_allowed: Callable[[], bool]  # no e-stop latched, not fallen: the robot may be moved to safety
    refusal: Callable[[], CommandReply | None]  # why nothing may start now (the latch, teleop)
    plan: Callable[[str], Plan]  # a command's plan, as the planner reads it (`PlanningError` if it cannot)


class BehaviourRunner:
    """Starts, pauses, resumes and stops behaviours, and runs the `behaviour` step on the task thread."""

    def __init__(
        self, registry: Registry, parts: BehaviourParts, lock: threading.RLock, publish: Callable[..., Any]
    ) -> None:
        self._registry = registry
        self._p = parts
        self._lock = lock
        self._publish = publish
        self._run: Run | None = None
        self._next_id = 1

    # ---------------------------------------------------------------------------------------------------------
    # what the operator sees

    def describe(self) -> tuple[BehaviourInfo, ...]:
        return self._registry.infos()

    def status(self) -> BehaviourStatus | None:
        run = self._reconciled()
        return run.status() if run is not None else None

    def active(self) -> Run | None:
        run = self._reconciled()
        return run if run is not None and not run.state.finished else None

    def plan_refusal(self) -> CommandReply | None:
        """Plans wait while a behaviour runs or is paused: the operator stops it first."""
        run = self.active()
        if run is None:
            return None
        return CommandReply(
            False, f"the {run.name} behaviour is {run.state.value}: stop it first", Refusal.BUSY, (f"{run.name} busy",)
        )

    def teleop_refusal(self) -> CommandReply | None:
        """Teleop waits while a behaviour runs (paused, the operator may drive, as with a paused plan)."""
        run = self.active()
        if run is None or run.state == BehaviourState.PAUSED:
            return None
        return CommandReply(
            False, f"the {run.name} behaviour is running: pause or stop it to teleoperate", Refusal.BUSY
        )

    # ---------------------------------------------------------------------------------------------------------
    # the operator's controls

    def take_command(self, command: RunCommand) -> CommandReply | None:
        """A typed or spoken command about behaviours ("start the patrol", "stop the tour"), or one for a running
        behaviour that listens (the demo): served here; None when it is a command for the planner."""
        world = self._p.world()
        intent = read_intent(command.text, tuple(self._registry.behaviours), world.places, world.objects)
        run = self.active()
        if intent is None and run is not None:
            bare = control_word(command.text)
            if bare is not None:
                intent = Intent(bare, run.name)
            elif run.state == BehaviourState.RUNNING and run.behaviour.listens:
                with self._lock:
                    run.inbox.append(command.text)
                self._publish(
                    "behaviour/heard", f"{run.name} heard: {command.text}", run_id=run.run_id, text=command.text
                )
                return CommandReply(True, f"passed to the {run.name} behaviour", command_id=run.command_id)
        if intent is None:
            return None
        if intent.action == "start":
            return self.start(StartBehaviour(intent.name, intent.params, source="command"))
        if intent.action == "stop":
            return self.stop(StopBehaviour())
        if intent.action == "pause":
            return self.pause(PauseBehaviour())
        return self.resume()

    def start(self, command: StartBehaviour) -> CommandReply:
        cls = self._registry.get(command.name)
        if cls is None:
            known = ", ".join(sorted(self._registry.behaviours)) or "none"
            message = f"unknown behaviour {command.name!r} (known: {known})"
            return CommandReply(False, message, Refusal.INVALID, (f"name: {message}",))
        names = {"places": self._p.layout.place_names, "objects": self._p.layout.object_names}
        try:
            params = cls.check_params(command.params, names)
            behaviour = cls(params)
        except BadParameter as exc:
            return CommandReply(False, str(exc), Refusal.INVALID, (f"{exc.name}: {exc}",))
        except Exception as exc:  # the user's constructor
            message = f"the {cls.name} behaviour could not be set up: {type(exc).__name__}: {exc}"
            return CommandReply(False, message, Refusal.INVALID, (message,))
        with self._lock:
            if refusal := self._p.refusal():
                return refusal
            if busy := self.plan_refusal():
                return busy
            run = Run(self._next_id, behaviour, params, cls.states[0], self._p.parts.clock.now())
            self._next_id += 1
            previous, self._run = self._run, run
            text = f"behaviour {cls.name}" + "".join(f" {k}={v}" for k, v in command.params.items())
            step = Step(BEHAVIOUR_ACTION, {"name": cls.name, "run": str(run.run_id)})
            reply = self._p.tasks.enqueue(text, Plan((step,)), new_command=True, approved=True)
            if not reply.accepted:
                self._run = previous
                return reply
            run.command_id = reply.command_id
        self._publish(
            "behaviour/started",
            f"behaviour {cls.name} started" + (f" ({_params_text(params)})" if params else ""),
            run_id=run.run_id,
            name=cls.name,
            params=params,
            command_id=reply.command_id,
            source=command.source,
        )
        return CommandReply(True, f"behaviour {cls.name} started (run {run.run_id})", command_id=reply.command_id)

    def stop(self, command: StopBehaviour) -> CommandReply:
        with self._lock:
            run = self.active()
            if run is None:
                return CommandReply(False, "no behaviour is running", Refusal.NOTHING_TO_DO)
            run.stop_reason = command.reason
            if run.state == BehaviourState.PAUSED:  # nothing runs it: it ends here
                self._end(run, BehaviourState.STOPPED, command.reason)
        self._p.tasks.cancel(command.reason)
        return CommandReply(True, f"stopping the {run.name} behaviour", command_id=run.command_id)

    def pause(self, command: PauseBehaviour) -> CommandReply:
        with self._lock:
            run = self.active()
            if run is None or run.state != BehaviourState.RUNNING:
                return CommandReply(False, "no behaviour is running", Refusal.NOTHING_TO_DO)
            run.pause_reason = command.reason
        reply = self._p.tasks.pause()
        return replace(reply, message=f"pausing the {run.name} behaviour") if reply.accepted else reply

    def resume(self) -> CommandReply:
        with self._lock:
            run = self.active()
            if run is None or run.state != BehaviourState.PAUSED:
                return CommandReply(False, "no behaviour is paused", Refusal.NOTHING_TO_DO)
        reply = self._p.tasks.resume()
        return replace(reply, message=f"resuming the {run.name} behaviour") if reply.accepted else reply

    def estopped(self, cause: str = "") -> None:
        """The e-stop latched (`cause`: who latched it, and why): a paused behaviour ends, a running one ends as its
        step is cancelled; either says the cause."""
        with self._lock:
            run = self._run
            if run is None or run.state.finished:
                return
            reason = f"stopped by the e-stop ({cause})" if cause else "stopped by the e-stop"
            if run.state in (BehaviourState.PAUSED, BehaviourState.QUEUED):
                self._end(run, BehaviourState.STOPPED, reason)
            else:
                run.stop_reason = run.stop_reason or reason

    # ---------------------------------------------------------------------------------------------------------
    # the `behaviour` step, on the task thread

    def run_step(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        with self._lock:
            run = self._run
            if run is None or str(run.run_id) != args.get("run") or run.state.finished:
                raise StepFailed(f"behaviour run {args.get('run')} is no longer current")
            resumed = run.state == BehaviourState.PAUSED
            run.state = BehaviourState.RUNNING
        if resumed:
            self._publish(
                "behaviour/resumed", f"behaviour {run.name} resumed in {run.machine_state}", run_id=run.run_id
            )
        try:
            self._machine(run, ctx)
        except Cancelled:
            self._interrupted(run, ctx)
            raise
        except (BehaviourFailed, StepFailed) as exc:
            self._failed(run, str(exc))
        except Exception as exc:  # the user's code: contained, the robot made safe
            self._failed(run, f"error in the {run.name} behaviour: {type(exc).__name__}: {exc}")
        with self._lock:
            if run.state == BehaviourState.FAILED:
                raise StepFailed(run.reason)
            run.progress = 1.0
            self._end(run, BehaviourState.SUCCEEDED, "")
        return f"behaviour {run.name} succeeded"

    def _machine(self, run: Run, ctx: ExecutionContext) -> None:
        states = type(run.behaviour).states
        while True:
            state = run.machine_state
            following = self._contained(run, state, ctx)
            if following is None:
                return
            if following not in states:
                raise BehaviourFailed(f"state {state!r} went to {following!r}, which is not one of its states")
            with self._lock:
                run.machine_state = following
            self._publish(
                "behaviour/state",
                f"{run.name}: {state} -> {following}",
                run_id=run.run_id,
                state=following,
                previous=state,
            )

    def _contained(self, run: Run, state: str, ctx: ExecutionContext) -> str | None:
        """Run the state's step in its own thread; it ends with the behaviour's pause or stop (then `Cancelled`),
        or with `BehaviourFailed` when it overruns the behaviour's step timeout."""
        step_cancel = threading.Event()
        tasks = self._p.tasks
        step_ctx = replace(
            ctx, cancel=step_cancel, wait_sim=lambda seconds: tasks.wait_sim(seconds, step_cancel), upcoming=()
        )
        p = self._p
        robot = BehaviourRobot(
            p.parts,
            p.skills,
            p.capabilities,
            p.layout,
            p.world,
            step_ctx,
            RunReporter(run, self._lock, self._publish),
            p.plan,
        )
        outcome: dict[str, Any] = {}

        def body() -> None:
            try:
                outcome["next"] = run.behaviour.step(state, robot)
            except BaseException as exc:  # handed to the task thread
                outcome["error"] = exc

        thread = threading.Thread(target=body, name=f"behaviour-{run.name}", daemon=True)
        timeout = type(run.behaviour).step_timeout_s
        deadline = p.parts.clock.now() + timeout
        thread.start()
        try:
            while thread.is_alive():
                if p.parts.clock.now() > deadline + robot.rested_s:  # a rest for hot servos is not the step's
                    raise BehaviourFailed(f"state {state!r} overran its step timeout of {timeout:g} s")
                ctx.wait_sim(0.02)
        finally:
            if thread.is_alive():
                step_cancel.set()
                thread.join(STEP_EXIT_WALL_S)
        error = outcome.get("error")
        if isinstance(error, Exception):
            raise error
        if error is not None:  # SystemExit and the like: they end the behaviour, never the task thread
            raise BehaviourFailed(f"state {state!r} ended with {type(error).__name__}")
        return outcome.get("next")

    # ---------------------------------------------------------------------------------------------------------
    # endings

    def _interrupted(self, run: Run, ctx: ExecutionContext) -> None:
        fault = ctx.fault()
        if fault is not None:
            self._failed(run, fault)
            return
        if ctx.pausing():
            self._make_safe()
            with self._lock:
                run.state = BehaviourState.PAUSED
            self._publish(
                "behaviour/paused",
                f"behaviour {run.name} {run.pause_reason or 'paused'} (in {run.machine_state})",
                run_id=run.run_id,
                reason=run.pause_reason,
            )
            return
        moved = self._make_safe()
        with self._lock:
            reason = run.stop_reason or ("stopped by the e-stop" if not moved else "cancelled")
            self._end(run, BehaviourState.STOPPED, reason)

    def _failed(self, run: Run, reason: str) -> None:
        self._make_safe()
        with self._lock:
            self._end(run, BehaviourState.FAILED, reason)

    def _end(self, run: Run, state: BehaviourState, reason: str) -> None:
        """Under the lock: the run is over."""
        if run.state.finished:
            return
        run.state, run.reason, run.ended_sim_s = state, reason, self._p.parts.clock.now()
        level = Level.OK if state == BehaviourState.SUCCEEDED else Level.WARN
        self._publish(
            "behaviour/finished",
            f"behaviour {run.name} {state.value}" + (f": {reason}" if reason else ""),
            level,
            run_id=run.run_id,
            name=run.name,
            state=state.value,
            reason=reason,
            machine_state=run.machine_state,
            feedback=list(run.feedback),
            sim_s=round(run.ended_sim_s - run.started_sim_s, 3),
        )

    def _make_safe(self) -> bool:
        """Leave the robot standing where it is, head ahead, arm stowed (carrying pose if it holds something);
        nothing moves under an e-stop or after a fall. Whether it could move."""
        parts = self._p.parts
        if not self._p.motion_allowed():
            return False
        cancel = threading.Event()
        ctx = ExecutionContext(cancel=cancel, say=lambda text: None, wait_sim=lambda s: self._safe_wait(s, cancel))
        with contextlib.suppress(Cancelled, StepFailed, BehaviourFailed):
            parts.legs.drive(Velocity())
            waited = 0.0
            while parts.legs.moving and waited < SETTLE_SIM_S:
                ctx.wait_sim(0.05)
                waited += 0.05
            parts.head.point(0.0, DEFAULT_TILT)
            arm = parts.arm
            if arm.active and arm.held is not None:
                arm.release(arm.motion().targets)
            elif arm.active:
                self._p.skills.manipulate.arm_body(ctx).stow_arm()
        return True

    def _safe_wait(self, seconds: float, cancel: threading.Event) -> None:
        if not self._p.motion_allowed():
            cancel.set()
        self._p.tasks.wait_sim(seconds, cancel)

    def _reconciled(self) -> Run | None:
        """The current run, ended if the task runner ended its job while nothing ran it (cancelled while queued or
        paused, by a reset or the plan controls)."""
        with self._lock:
            run = self._run
            if run is None or run.state not in (BehaviourState.QUEUED, BehaviourState.PAUSED):
                return run
            shown = self._p.tasks.shown()
            ended = (PlanState.CANCELLED, PlanState.FAILED, PlanState.SUCCEEDED)
            if shown is not None and shown.command_id == run.command_id and shown.state in ended:
                detail = next((s.detail for s in shown.steps if s.detail), "cancelled")
                self._end(run, BehaviourState.STOPPED, run.stop_reason or detail)
            return run


def _params_text(params: dict[str, Any]) -> str:
    return ", ".join(f"{k}={', '.join(v) if isinstance(v, list) else v}" for k, v in params.items())
