from __future__ import annotations

import threading

from robot.interface import Plan, PlanState, Step, StepState
from robot.planning.executor import ExecutionContext, PlanExecutor, StepFailed, default_capabilities


def make_context(said: list[str], cancel: threading.Event | None = None) -> ExecutionContext:
    return ExecutionContext(cancel=cancel or threading.Event(), say=said.append, wait_sim=lambda s: None)


def run(plan: Plan, capabilities=None, cancel=None) -> tuple[PlanState, list[tuple[int, StepState, str]], list[str]]:
    said: list[str] = []
    updates: list[tuple[int, StepState, str]] = []
    result = PlanExecutor(capabilities or default_capabilities()).run(
        plan, make_context(said, cancel), lambda i, s, d: updates.append((i, s, d))
    )
    return result, updates, said


def final_states(updates) -> dict[int, StepState]:
    return {i: s for i, s, _ in updates}


def test_say_succeeds_and_is_spoken() -> None:
    result, updates, said = run(Plan((Step("say", {"text": "hello"}),)))
    assert result == PlanState.SUCCEEDED
    assert said == ["hello"]
    assert [s for _, s, _ in updates] == [StepState.RUNNING, StepState.SUCCEEDED]


def test_unbuilt_capability_fails_honestly_and_skips_the_rest() -> None:
    plan = Plan((Step("navigate_to", {"target": "kitchen counter"}), Step("say", {"text": "done"})))
    result, updates, said = run(plan)
    assert result == PlanState.FAILED
    assert said == []  # the confirmation is never spoken for work that was not done
    states = final_states(updates)
    assert states == {0: StepState.FAILED, 1: StepState.SKIPPED}
    reason = next(d for i, s, d in updates if s == StepState.FAILED)
    assert "navigation is not available" in reason


def test_capability_bug_fails_the_step_with_the_error() -> None:
    def broken(args, ctx):
        raise ZeroDivisionError("oops")

    result, updates, _ = run(Plan((Step("say", {"text": "x"}),)), {"say": broken})
    assert result == PlanState.FAILED
    assert "ZeroDivisionError: oops" in updates[-1][2]


def test_precise_failure_reason_is_kept() -> None:
    def slipped(args, ctx):
        raise StepFailed("grasp slipped")

    result, updates, _ = run(Plan((Step("say", {"text": "x"}),)), {"say": slipped})
    assert (result, updates[-1][1], updates[-1][2]) == (PlanState.FAILED, StepState.FAILED, "grasp slipped")


def test_cancel_stops_before_the_next_step() -> None:
    cancel = threading.Event()

    def cancel_during(args, ctx):
        cancel.set()
        return "ok"

    plan = Plan((Step("say", {"text": "a"}), Step("say", {"text": "b"})))
    result, updates, _ = run(plan, {"say": cancel_during}, cancel)
    assert result == PlanState.CANCELLED
    assert final_states(updates) == {0: StepState.SUCCEEDED, 1: StepState.CANCELLED}


def test_each_step_sees_the_steps_after_it_so_it_can_prepare_for_them() -> None:
    seen: list[tuple[str, ...]] = []

    def record(args, ctx: ExecutionContext) -> str:
        seen.append(tuple(step.action for step in ctx.upcoming))
        return "ok"

    capabilities = {**default_capabilities(), "navigate_to": record, "pick_object": record, "say": record}
    plan = Plan(
        (
            Step("navigate_to", {"target": "kitchen counter"}),
            Step("pick_object", {"object": "red mug"}),
            Step("say", {"text": "done"}),
        )
    )
    result, _, _ = run(plan, capabilities)
    assert result == PlanState.SUCCEEDED
    assert seen == [("pick_object", "say"), ("say",), ()]


def test_a_fault_that_stops_the_plan_fails_the_running_step_with_its_reason() -> None:
    """A fall cancels the plan; the step that was running fails with "fell", not "cancelled" (the operator did not
    cancel anything), and the rest is skipped. Without a fault, the same cancel stays a cancel."""

    def stopped_while_walking(args, ctx: ExecutionContext) -> str:
        ctx.cancel.set()
        ctx.check_cancelled()
        return "never"

    plan = Plan((Step("navigate_to", {"target": "kitchen counter"}), Step("say", {"text": "done"})))
    for fault, plan_state, step_state, detail, rest in (
        (None, PlanState.CANCELLED, StepState.CANCELLED, "cancelled while running", StepState.CANCELLED),
        ("fell (tilt 62 deg)", PlanState.FAILED, StepState.FAILED, "fell (tilt 62 deg)", StepState.SKIPPED),
    ):
        updates: list[tuple[int, StepState, str]] = []
        context = make_context([])
        context.fault = lambda fault=fault: fault
        result = PlanExecutor({"navigate_to": stopped_while_walking}).run(
            plan, context, lambda i, s, d, log=updates: log.append((i, s, d))
        )
        assert result == plan_state
        assert [(s, d) for i, s, d in updates if i == 0][-1] == (step_state, detail)
        assert final_states(updates)[1] == rest
