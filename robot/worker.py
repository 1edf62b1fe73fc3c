"""The robot worker: a fixed-rate control thread and a task thread, behind the `RobotPort` interface.

- The control thread owns the backend (MuJoCo or servos): it reads, computes targets, writes, steps, and
  publishes an immutable `RobotState` every tick. An e-stop wakes it at once, so the controlled stop is applied
  within one tick of the press, not at the next scheduled one.
- The task thread executes plans, one at a time, through the `PlanExecutor`.
- `submit()` is called from any thread (the web server): it plans and validates synchronously, so a bad command
  is refused with reasons and changes nothing.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from robot.control.posture import PostureController
from robot.control.priority import raise_thread_priority
from robot.control.stats import LoopStats
from robot.events import EventBus, Subscription
from robot.interface import (
    CancelPlan,
    Command,
    CommandReply,
    EStop,
    Event,
    ExecutePlan,
    Level,
    Mode,
    ObjectPose,
    Plan,
    PlanState,
    PlanStatus,
    Refusal,
    ReleaseEStop,
    Replan,
    RobotDescription,
    RobotState,
    RunCommand,
    StepState,
    StepStatus,
)
from robot.model import humanoid_v1
from robot.model.scene import scene_xml
from robot.model.world import WorldLayout
from robot.planning.executor import Cancelled, Capability, ExecutionContext, PlanExecutor, default_capabilities
from robot.planning.planner import Planner, PlanningError
from robot.planning.rules import RulesPlanner
from robot.planning.validator import validate_plan, validate_plan_json
from robot.planning.world_context import WorldContext
from robot.sim.backend import Measurements, MujocoSimBackend
from robot.state_board import StateBoard

MAX_COMMAND_CHARS = 500
# When the loop falls this many ticks behind, it stops trying to catch up (sim time would race wall time).
MAX_TICKS_BEHIND = 5


def _step_summary(steps: tuple[StepStatus, ...]) -> list[dict[str, str]]:
    return [{"action": s.action, "state": s.state.value, "detail": s.detail} for s in steps]


@dataclass
class _Job:
    status: PlanStatus
    plan: Plan
    cancel: threading.Event


class RobotWorker:
    """Runs the robot. Use `start()`, then talk to it only through the `RobotPort` methods."""

    def __init__(
        self,
        layout: WorldLayout,
        backend: MujocoSimBackend | None = None,
        planner: Planner | None = None,
        capabilities: dict[str, Capability] | None = None,
        realtime: bool = True,
        control_hz: float = 100.0,
    ) -> None:
        self.layout = layout
        self.backend = backend or MujocoSimBackend(layout)
        self.planner = planner or RulesPlanner()
        self.realtime = realtime
        self.control_hz = control_hz
        self.dt = 1.0 / control_hz
        self._executor = PlanExecutor(capabilities or default_capabilities())
        self._bus = EventBus(sim_clock=lambda: self._sim_time)
        self._stats = LoopStats(control_hz)
        self._posture = PostureController(self.backend.stand_targets())

        self._lock = threading.RLock()  # guards the fields below
        self._estop_latched = False
        self._estop_pending: tuple[EStop, float] | None = None
        self._fallen = False
        self._held_object: str | None = None
        self._current_job: _Job | None = None
        self._finished_job: _Job | None = None  # the last plan that ran, shown until the next one starts
        self._last_command: tuple[int, str] | None = None  # (command_id, text) of the command being served
        self._next_command_id = 1
        self._next_plan_id = 1
        self._revisions: dict[int, int] = {}

        self._jobs: queue.Queue[_Job | None] = queue.Queue()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._sim_time = 0.0
        self._board = StateBoard()
        self._threads: list[threading.Thread] = []
        self._description: RobotDescription | None = None
        self._publish_state(self.backend.read())

    # ----------------------------------------------------------------------------------------------------------
    # lifecycle

    def start(self) -> None:
        if self._threads:
            return
        self._stop.clear()
        self._threads = [
            threading.Thread(target=self._control_loop, name="robot-control", daemon=True),
            threading.Thread(target=self._task_loop, name="robot-tasks", daemon=True),
        ]
        for thread in self._threads:
            thread.start()
        self._bus.publish("worker/started", f"robot worker started ({'real time' if self.realtime else 'headless'})")

    def is_alive(self) -> bool:
        return bool(self._threads) and all(t.is_alive() for t in self._threads)

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        with self._lock:
            if self._current_job:
                self._current_job.cancel.set()
        self._jobs.put(None)
        for thread in self._threads:
            thread.join(timeout=5.0)
        self._threads = []

    # ----------------------------------------------------------------------------------------------------------
    # RobotPort

    def submit(self, command: Command) -> CommandReply:
        if isinstance(command, EStop):
            return self._latch_estop(command)
        if isinstance(command, ReleaseEStop):
            return self._release_estop(command)
        if isinstance(command, CancelPlan):
            return self._cancel_plan("cancelled by operator")
        if isinstance(command, RunCommand):
            return self._run_command(command)
        if isinstance(command, ExecutePlan):
            return self._execute_plan(command)
        if isinstance(command, Replan):
            return self._replan()
        return CommandReply(False, f"unknown command type {type(command).__name__}", Refusal.INVALID)

    def state(self) -> RobotState:
        return self._board.latest()

    def subscribe(self) -> Subscription:
        return self._bus.subscribe()

    def recent_events(self) -> list[Event]:
        return self._bus.history()

    def describe(self) -> RobotDescription:
        if self._description is None:
            self._description = RobotDescription(
                model_name=humanoid_v1.MODEL_NAME,
                seed=self.layout.seed,
                mjcf_xml=scene_xml(self.layout),
                joint_names=tuple(self.backend.joint_names),
                places=self.layout.place_names,
                objects=self.layout.object_names,
                control_hz=self.control_hz,
                physics_hz=1.0 / self.backend.physics_dt,
            )
        return self._description

    # ----------------------------------------------------------------------------------------------------------
    # helpers for headless runs and tests

    def wait_for(self, predicate: Callable[[RobotState], bool], timeout_s: float) -> bool:
        """Block until `predicate(state)` holds or the wall-clock timeout passes."""
        return self._board.wait_for(predicate, timeout_s)

    # ----------------------------------------------------------------------------------------------------------
    # e-stop

    def _latch_estop(self, command: EStop) -> CommandReply:
        received = time.time()
        with self._lock:
            if self._estop_latched:
                return CommandReply(True, "e-stop already latched")
            self._estop_latched = True
            self._estop_pending = (command, received)
            job = self._current_job
            if job:
                job.cancel.set()
            self._drain_queued_jobs("cancelled by e-stop")
        self._wake.set()  # the control thread applies the stop now, not at its next tick
        return CommandReply(True, "e-stop latched")

    def _apply_pending_estop(self) -> None:
        """Control thread: the controlled stop. Every joint holds its current reference; the plan is cancelled."""
        with self._lock:
            pending, self._estop_pending = self._estop_pending, None
        if pending is None:
            return
        command, received = pending
        self.backend.write(self._posture.freeze())
        applied = time.time()
        data: dict[str, Any] = {"source": command.source, "worker_latency_ms": (applied - received) * 1e3}
        if command.relayed_at_s is not None:
            data["server_latency_ms"] = (applied - command.relayed_at_s) * 1e3
        if command.client_time_s is not None:
            data["latency_ms"] = (applied - command.client_time_s) * 1e3
        self._bus.publish("estop/latched", f"E-STOP latched ({command.source}): holding position", Level.ERROR, **data)
        self._publish_state(self.backend.read())

    def _release_estop(self, command: ReleaseEStop) -> CommandReply:
        with self._lock:
            if not self._estop_latched:
                return CommandReply(False, "e-stop is not latched", Refusal.NOT_LATCHED)
            if self._estop_pending is not None:
                return CommandReply(False, "e-stop is still being applied; try again", Refusal.ESTOP_LATCHED)
            self._estop_latched = False
        self._bus.publish(
            "estop/released", f"E-STOP released ({command.source}); the robot stays still until the next command"
        )
        return CommandReply(True, "e-stop released; send a command or replan to resume")

    # ----------------------------------------------------------------------------------------------------------
    # commands and plans

    def _refuse_if_unsafe(self) -> CommandReply | None:
        if self._estop_latched:
            return CommandReply(False, "e-stop is latched: release it first", Refusal.ESTOP_LATCHED)
        if self._fallen:
            return CommandReply(False, "the robot has fallen: it must be reset first", Refusal.ESTOP_LATCHED)
        return None

    def _world_context(self) -> WorldContext:
        return WorldContext.from_layout(self.layout, held_object=self._held_object)

    def _run_command(self, command: RunCommand) -> CommandReply:
        text = command.text.strip()
        if not text:
            return CommandReply(False, "empty command", Refusal.INVALID, ("command text is empty",))
        if len(text) > MAX_COMMAND_CHARS:
            return CommandReply(
                False, "command too long", Refusal.INVALID, (f"at most {MAX_COMMAND_CHARS} characters",)
            )
        with self._lock:
            if refusal := self._refuse_if_unsafe():
                return refusal
        try:
            plan = self.planner.plan(text, self._world_context())
        except PlanningError as exc:
            self._bus.publish("plan/rejected", f"could not plan {text!r}: {exc}", Level.WARN, text=text)
            return CommandReply(False, str(exc), Refusal.INVALID, (str(exc),))
        checked, errors = validate_plan(plan, self._world_context())
        if checked is None:
            self._bus.publish("plan/rejected", f"invalid plan for {text!r}", Level.WARN, text=text, errors=errors)
            return CommandReply(False, "the planner produced an invalid plan", Refusal.INVALID, tuple(errors))
        return self._enqueue(text, checked, new_command=True)

    def _execute_plan(self, command: ExecutePlan) -> CommandReply:
        with self._lock:
            if refusal := self._refuse_if_unsafe():
                return refusal
        checked, errors = validate_plan_json(command.plan_json, self._world_context())
        if checked is None:
            return CommandReply(False, "invalid plan", Refusal.INVALID, tuple(errors))
        return self._enqueue(command.text or "(operator plan)", checked, new_command=True)

    def _replan(self) -> CommandReply:
        with self._lock:
            if refusal := self._refuse_if_unsafe():
                return refusal
            last = self._last_command
        if last is None:
            return CommandReply(False, "no command to replan", Refusal.NOTHING_TO_REPLAN)
        command_id, text = last
        try:
            plan = self.planner.plan(text, self._world_context())
        except PlanningError as exc:
            return CommandReply(False, str(exc), Refusal.INVALID, (str(exc),))
        checked, errors = validate_plan(plan, self._world_context())
        if checked is None:
            return CommandReply(False, "the planner produced an invalid plan", Refusal.INVALID, tuple(errors))
        return self._enqueue(text, checked, new_command=False, command_id=command_id)

    def _enqueue(self, text: str, plan: Plan, new_command: bool, command_id: int | None = None) -> CommandReply:
        with self._lock:
            if refusal := self._refuse_if_unsafe():  # an e-stop may have come in while planning
                return refusal
            if new_command:
                command_id = self._next_command_id
                self._next_command_id += 1
                self._bus.publish("command/received", f"command: {text}", command_id=command_id, text=text)
            assert command_id is not None
            revision = self._revisions.get(command_id, 0) + 1
            self._revisions[command_id] = revision
            plan_id = self._next_plan_id
            self._next_plan_id += 1
            self._last_command = (command_id, text)
            if self._current_job:
                self._current_job.cancel.set()  # the newest command or plan revision preempts the running one
            self._drain_queued_jobs("superseded by a newer plan")
            status = PlanStatus(
                plan_id=plan_id,
                command_id=command_id,
                command_text=text,
                revision=revision,
                state=PlanState.RUNNING,
                steps=tuple(StepStatus(i, s.action, dict(s.args)) for i, s in enumerate(plan.steps)),
            )
            self._bus.publish(
                "plan/created",
                f"plan {plan_id} (revision {revision}): " + ", ".join(s.action for s in plan.steps),
                plan_id=plan_id,
                command_id=command_id,
                revision=revision,
                text=text,
                plan=plan.to_dict(),
            )
            self._jobs.put(_Job(status, plan, threading.Event()))
        return CommandReply(True, f"plan {plan_id} queued", command_id=command_id, plan=plan)

    def _cancel_plan(self, reason: str) -> CommandReply:
        with self._lock:
            job = self._current_job
            if job:
                job.cancel.set()
            self._drain_queued_jobs(reason)
        return CommandReply(True, "plan cancelled" if job else "no plan running")

    def _drain_queued_jobs(self, reason: str) -> None:
        while True:
            try:
                job = self._jobs.get_nowait()
            except queue.Empty:
                return
            if job is None:
                self._jobs.put(None)
                return
            job.cancel.set()
            steps = tuple(replace(s, state=StepState.CANCELLED, detail=reason) for s in job.status.steps)
            job.status = replace(job.status, state=PlanState.CANCELLED, steps=steps)
            self._finished_job = job
            self._bus.publish(
                "plan/finished",
                f"plan {job.status.plan_id} {reason}",
                Level.WARN,
                plan_id=job.status.plan_id,
                state=PlanState.CANCELLED.value,
                steps=_step_summary(steps),
            )

    # ----------------------------------------------------------------------------------------------------------
    # task thread

    def _task_loop(self) -> None:
        while not self._stop.is_set():
            job = self._jobs.get()
            if job is None:
                return
            with self._lock:
                if job.cancel.is_set() or self._estop_latched:
                    continue
                self._current_job = job
                # A new plan starts from the standing posture (a move, so only after an explicit command).
                self._posture.move_to(self.backend.stand_targets())
            context = ExecutionContext(
                cancel=job.cancel,
                say=lambda text: self._bus.publish("speech/say", text, text=text),
                wait_sim=lambda seconds, cancel=job.cancel: self._wait_sim(seconds, cancel),
                held_object=lambda: self._held_object,
            )
            result = self._executor.run(job.plan, context, lambda i, st, d, j=job: self._on_step(j, i, st, d))
            with self._lock:
                job.status = replace(job.status, state=result)
                self._current_job = None
                self._finished_job = job
            level = Level.OK if result == PlanState.SUCCEEDED else Level.WARN
            failed = [s for s in job.status.steps if s.state == StepState.FAILED]
            message = f"plan {job.status.plan_id} {result.value}" + (f": {failed[0].detail}" if failed else "")
            self._bus.publish(
                "plan/finished", message, level, plan_id=job.status.plan_id, state=result.value,
                steps=_step_summary(job.status.steps),
            )  # fmt: skip

    def _on_step(self, job: _Job, index: int, state: StepState, detail: str) -> None:
        now = self._sim_time
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
        self._bus.publish(
            "plan/step", f"step {index + 1} {new.action}: {state.value}" + (f" ({detail})" if detail else ""),
            level, plan_id=job.status.plan_id, index=index, action=new.action, args=new.args, state=state.value,
            detail=detail, sim_start_s=new.sim_start_s, sim_end_s=new.sim_end_s,
        )  # fmt: skip

    def _wait_sim(self, seconds: float, cancel: threading.Event) -> None:
        target = self._sim_time + seconds
        while self._sim_time < target:
            if cancel.is_set():
                raise Cancelled()
            if self._stop.is_set():
                raise Cancelled()
            cancel.wait(0.002)

    # ----------------------------------------------------------------------------------------------------------
    # control thread

    def _control_loop(self) -> None:
        if self.realtime:
            priority = raise_thread_priority()
            self._bus.publish("control/priority", f"control loop at {self.control_hz:.0f} Hz with {priority}",
                              Level.OK if priority.startswith("real-time") else Level.WARN)  # fmt: skip
        next_deadline = time.perf_counter() + self.dt
        while not self._stop.is_set():
            if self.realtime:
                remaining = next_deadline - time.perf_counter()
                if remaining > 0:
                    if self._wake.wait(remaining):
                        self._wake.clear()
                        self._apply_pending_estop()
                    continue
            started = time.perf_counter()
            try:
                self._tick()
            except Exception as exc:  # the loop must survive a controller bug: stop safely and report it
                self._bus.publish("control/error", f"control tick failed: {exc!r}", Level.ERROR)
                self.submit(EStop(source="control-error"))
            finished = time.perf_counter()
            missed = self.realtime and finished > next_deadline + self.dt
            self._stats.record_tick(finished - started, missed)
            next_deadline += self.dt
            if self.realtime and finished - next_deadline > MAX_TICKS_BEHIND * self.dt:
                next_deadline = finished + self.dt

    def _tick(self) -> None:
        """One control period: targets out, physics (or the servos) forward, measurements in, state published."""
        self._apply_pending_estop()
        self.backend.write(self._posture.update(self.dt))
        self.backend.step(self.dt)
        measured = self.backend.read()
        self._sim_time = measured.sim_time_s
        self._stats.update_rtf(self._sim_time)
        if measured.fallen and not self._fallen:
            self._on_fall(measured)
        self._publish_state(measured)

    def _on_fall(self, measured: Measurements) -> None:
        with self._lock:
            self._fallen = True
            if self._current_job:
                self._current_job.cancel.set()
        self._bus.publish("robot/fell", f"the robot fell (tilt {measured.tilt_deg:.0f} deg)", Level.ERROR,
                          tilt_deg=measured.tilt_deg, height_m=float(measured.base_position[2]))  # fmt: skip

    def _publish_state(self, measured: Measurements) -> None:
        with self._lock:
            job = self._current_job
            latched = self._estop_latched
            mode = Mode.FALLEN if self._fallen else Mode.ESTOP if latched else Mode.EXECUTING if job else Mode.IDLE
            shown = job or self._finished_job
            plan_status = shown.status if shown else None
        position = measured.base_position
        self._board.publish(
            RobotState(
                sim_time_s=measured.sim_time_s,
                wall_time_s=time.time(),
                mode=mode,
                estop_latched=latched,
                base_position=(float(position[0]), float(position[1]), float(position[2])),
                base_yaw_rad=measured.yaw_rad,
                tilt_deg=measured.tilt_deg,
                fallen=measured.fallen,
                qpos=tuple(self.backend.qpos().tolist()),
                objects=tuple(ObjectPose(n, p) for n, p in self.backend.object_positions().items()),
                held_object=self._held_object,
                plan=plan_status,
                control=self._stats.snapshot(),
            )
        )
