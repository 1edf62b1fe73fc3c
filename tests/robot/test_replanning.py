"""The executor replans a command whose step failed, from where the robot is, a bounded number of times; the
planner is told what failed and what was done; an operator's explicit plan and a fall are not replanned."""

from __future__ import annotations

from robot.interface import ExecutePlan, Plan, PlanState, RunCommand, Step
from robot.planning.context import PlanningContext
from robot.planning.rules import RulesPlanner


class RecordingPlanner:
    """The rules planner, keeping every context it was asked in."""

    name = "rules"

    def __init__(self) -> None:
        self.contexts: list[PlanningContext] = []

    def plan(self, text: str, context: PlanningContext) -> Plan:
        self.contexts.append(context)
        return RulesPlanner().plan(text, context)


def finished_for_good(command_id: int):
    return lambda s: (
        s.plan is not None
        and s.plan.command_id == command_id
        and s.plan.state != PlanState.RUNNING
        and not s.plan.replanning
    )


def test_a_failed_step_is_replanned_twice_with_the_failure_then_the_command_fails(make_worker) -> None:
    planner = RecordingPlanner()
    # no perception: navigation fails at once ("needs the lidar's map"), which a replan cannot cure
    worker = make_worker(realtime=False, planner=planner, max_auto_replans=2)
    subscription = worker.subscribe()
    reply = worker.submit(RunCommand("go to the dock"))
    assert reply.accepted
    assert worker.wait_for(finished_for_good(reply.command_id), 20.0)
    state = worker.state()
    assert state.plan.state == PlanState.FAILED
    assert state.plan.revision == 3  # the first plan and two automatic replans
    assert len(planner.contexts) == 3
    retry = planner.contexts[1]
    assert retry.failure is not None and "step 1 navigate_to failed" in retry.failure
    assert "needs the lidar's map" in retry.failure
    kinds = []
    while (event := subscription.get(timeout=0.05)) is not None:
        kinds.append(event.kind)
    assert kinds.count("plan/replanning") == 2
    assert kinds.count("plan/created") == 3


def test_the_memory_tells_the_next_command_how_the_last_one_ended(make_worker) -> None:
    planner = RecordingPlanner()
    worker = make_worker(realtime=False, planner=planner, max_auto_replans=0)
    first = worker.submit(RunCommand("go to the dock"))
    assert worker.wait_for(finished_for_good(first.command_id), 20.0)
    second = worker.submit(RunCommand("say hello"))
    assert worker.wait_for(finished_for_good(second.command_id), 20.0)
    history = planner.contexts[-1].history
    assert [t.command for t in history] == ["go to the dock"]
    assert history[0].outcome.startswith("failed: step 1 navigate_to failed")
    assert history[0].plan is not None and history[0].plan.steps[0] == Step("navigate_to", {"target": "charging dock"})


def test_an_operators_plan_is_not_replanned(make_worker) -> None:
    planner = RecordingPlanner()
    worker = make_worker(realtime=False, planner=planner, max_auto_replans=2)
    reply = worker.submit(ExecutePlan({"steps": [{"action": "navigate_to", "args": {"target": "dock"}}]}))
    assert worker.wait_for(finished_for_good(reply.command_id), 20.0)
    assert worker.state().plan.state == PlanState.FAILED and worker.state().plan.revision == 1
    assert planner.contexts == []
