"""Runs a plan's steps in order with per-step status, and stays honest about what the robot can do.

Each action is served by a capability (a callable). An action whose capability has not been built raises
`CapabilityUnavailable`, and the step fails with that reason: never a fake success.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from robot.interface import Plan, PlanState, Step, StepState


class StepFailed(Exception):
    """A step could not be done; the message is the precise reason shown to the operator."""


class CapabilityUnavailable(StepFailed):
    """The action exists in the vocabulary but this build cannot perform it yet."""


class Cancelled(Exception):
    """The plan was cancelled (e-stop or operator) while a step was running."""


@dataclass
class ExecutionContext:
    """What a capability may use while it runs."""

    cancel: threading.Event
    say: Callable[[str], None]
    wait_sim: Callable[[float], None]  # block until this much simulated time has passed (or cancel)
    held_object: Callable[[], str | None] = field(default=lambda: None)
    # The plan's steps after the running one: a step may prepare for them (navigation stops where the next pick
    # can reach its object).
    upcoming: tuple[Step, ...] = ()
    # Why the plan was stopped, when a fault stopped it (a fall) rather than the operator: the running step then
    # fails with this reason instead of counting as cancelled, so the operator and a replanner see what happened.
    fault: Callable[[], str | None] = field(default=lambda: None)
    # True when `cancel` was set to pause the plan rather than end it: the running step is left to run again.
    pausing: Callable[[], bool] = field(default=lambda: False)

    def check_cancelled(self) -> None:
        if self.cancel.is_set():
            raise Cancelled()


Capability = Callable[[dict[str, str], ExecutionContext], str]  # returns a detail string on success


def unavailable(reason: str) -> Capability:
    def run(args: dict[str, str], ctx: ExecutionContext) -> str:
        raise CapabilityUnavailable(reason)

    return run


# How long saying a word takes: espeak-ng's default rate, 175 words per minute.
SPEECH_S_PER_WORD = 60.0 / 175.0
MAX_SPEECH_S = 5.0


def say_capability(args: dict[str, str], ctx: ExecutionContext) -> str:
    ctx.say(args["text"])
    # the step lasts as long as the words take to say
    ctx.wait_sim(min(MAX_SPEECH_S, SPEECH_S_PER_WORD * len(args["text"].split())))
    return f'said "{args["text"]}"'


def default_capabilities() -> dict[str, Capability]:
    """What this build can do. Later capabilities (walking, perception, grasping) replace the placeholders."""
    return {
        "say": say_capability,
        "navigate_to": unavailable("navigation is not available in this build: no path planner yet (use teleop)"),
        "detect_object": unavailable("object detection is not available in this build: no camera pipeline yet"),
        "pick_object": unavailable("grasping is not available in this build: the hands have no grippers yet"),
        "place_object": unavailable("placing is not available in this build: the hands have no grippers yet"),
    }


StepCallback = Callable[[int, StepState, str], None]


class PlanExecutor:
    """Executes one plan at a time; reports each step's state through `on_step`."""

    def __init__(self, capabilities: dict[str, Capability]) -> None:
        self._capabilities = capabilities

    def run(self, plan: Plan, ctx: ExecutionContext, on_step: StepCallback, start: int = 0) -> PlanState:
        """Run the steps from `start` (a resumed plan goes on from its paused step)."""
        for index, step in enumerate(plan.steps):
            if index < start:
                continue
            if ctx.cancel.is_set():
                if ctx.pausing():
                    on_step(index, StepState.PAUSED, "paused: runs on resume")
                    return PlanState.PAUSED
                self._skip_rest(plan, index, on_step, StepState.CANCELLED, "plan cancelled")
                return PlanState.CANCELLED
            on_step(index, StepState.RUNNING, "")
            capability = self._capabilities.get(step.action)
            try:
                if capability is None:
                    raise CapabilityUnavailable(f"no capability for action {step.action!r}")
                detail = capability(step.args, replace(ctx, upcoming=tuple(plan.steps[index + 1 :])))
            except Cancelled:
                if ctx.pausing() and ctx.fault() is None:
                    on_step(index, StepState.PAUSED, "paused while running: runs again on resume")
                    return PlanState.PAUSED
                fault = ctx.fault()
                if fault is not None:
                    on_step(index, StepState.FAILED, fault)
                    self._skip_rest(plan, index + 1, on_step, StepState.SKIPPED, f"not run: step {index + 1} failed")
                    return PlanState.FAILED
                on_step(index, StepState.CANCELLED, "cancelled while running")
                self._skip_rest(plan, index + 1, on_step, StepState.CANCELLED, "plan cancelled")
                return PlanState.CANCELLED
            except StepFailed as exc:
                on_step(index, StepState.FAILED, str(exc))
                self._skip_rest(plan, index + 1, on_step, StepState.SKIPPED, f"not run: step {index + 1} failed")
                return PlanState.FAILED
            except Exception as exc:  # a bug in a capability must not kill the worker
                on_step(index, StepState.FAILED, f"internal error: {type(exc).__name__}: {exc}")
                self._skip_rest(plan, index + 1, on_step, StepState.SKIPPED, f"not run: step {index + 1} failed")
                return PlanState.FAILED
            on_step(index, StepState.SUCCEEDED, detail)
        return PlanState.SUCCEEDED

    @staticmethod
    def _skip_rest(plan: Plan, start: int, on_step: StepCallback, state: StepState, detail: str) -> None:
        for index in range(start, len(plan.steps)):
            on_step(index, state, detail)
