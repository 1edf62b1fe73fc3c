"""The operator's hold on plans: approve before executing, edit a plan, pause and resume, reject."""

from __future__ import annotations

import time

from robot.interface import (
    ApprovePlan,
    CancelPlan,
    EStop,
    ExecutePlan,
    PausePlan,
    PlanState,
    Refusal,
    ReleaseEStop,
    ResumePlan,
    RunCommand,
    SetApproval,
    StepState,
)


def succeeded(command_id: int):
    return lambda s: s.plan is not None and s.plan.command_id == command_id and s.plan.state == PlanState.SUCCEEDED


def test_with_approval_required_a_plan_waits_then_runs_when_approved(make_worker) -> None:
    worker = make_worker(realtime=False, approve_plans=True)
    reply = worker.submit(RunCommand("say hello"))
    assert reply.accepted and "awaits approval" in reply.message
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.AWAITING_APPROVAL, 30.0)
    waiting_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s >= waiting_at + 0.5, 30.0)  # and it waits
    state = worker.state()
    assert state.approval_required
    assert state.plan.state == PlanState.AWAITING_APPROVAL and state.plan.steps[0].state == StepState.PENDING
    stale = worker.submit(ApprovePlan(plan_id=state.plan.plan_id + 7))
    assert stale.refusal == Refusal.INVALID and "no longer awaits approval" in stale.message
    assert worker.submit(ApprovePlan(plan_id=state.plan.plan_id)).accepted
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.SUCCEEDED, 10.0)
    assert worker.submit(ApprovePlan()).refusal == Refusal.NOTHING_TO_DO


def test_a_plan_awaiting_approval_can_be_rejected_or_edited(make_worker) -> None:
    worker = make_worker(realtime=False, approve_plans=True)
    first = worker.submit(RunCommand("say hello"))
    assert worker.submit(CancelPlan()).accepted
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.CANCELLED, 30.0)
    assert worker.submit(ApprovePlan()).refusal == Refusal.NOTHING_TO_DO

    second = worker.submit(RunCommand("say hello"))
    assert second.command_id != first.command_id
    edited = {"steps": [{"action": "say", "text": "good morning"}]}  # the seed's flat shape
    stale = worker.submit(ExecutePlan(edited, command_id=first.command_id))
    assert stale.refusal == Refusal.INVALID
    reply = worker.submit(ExecutePlan(edited, command_id=second.command_id))
    assert reply.accepted and reply.command_id == second.command_id
    # the operator's edit runs at once, as the command's next revision
    assert worker.wait_for(
        lambda s: s.plan is not None and s.plan.revision == 2 and s.plan.state == PlanState.SUCCEEDED, 10.0
    )
    assert worker.state().plan.steps[0].detail == 'said "good morning"'


def test_an_automatic_replan_waits_for_approval_too(make_worker) -> None:
    worker = make_worker(realtime=False, approve_plans=True, max_auto_replans=1)
    worker.submit(RunCommand("go to the dock"))  # fails at once: no perception in this worker
    assert worker.submit(ApprovePlan()).accepted
    assert worker.wait_for(
        lambda s: s.plan is not None and s.plan.revision == 2 and s.plan.state == PlanState.AWAITING_APPROVAL, 20.0
    )


def test_approval_can_be_switched_off_and_on(make_worker) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(SetApproval(True)).accepted
    worker.submit(RunCommand("say hi"))
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.AWAITING_APPROVAL, 30.0)
    assert worker.submit(SetApproval(False)).accepted
    reply = worker.submit(RunCommand("say hi"))
    assert "queued" in reply.message
    assert worker.wait_for(succeeded(reply.command_id), 10.0)


def test_pause_interrupts_the_running_step_and_resume_runs_it_again_then_the_rest(make_worker) -> None:
    worker = make_worker(realtime=True)
    plan = {
        "steps": [{"action": "say", "text": "one"}, {"action": "wait", "seconds": 2}, {"action": "say", "text": "done"}]
    }
    assert worker.submit(ExecutePlan(plan)).accepted
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.steps[1].state == StepState.RUNNING, 10.0)
    assert worker.submit(PausePlan()).accepted
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.PAUSED, 30.0)
    paused = worker.state().plan
    assert [s.state for s in paused.steps] == [StepState.SUCCEEDED, StepState.PAUSED, StepState.PENDING]
    paused_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s >= paused_at + 0.5, 30.0)
    assert worker.state().plan.state == PlanState.PAUSED  # nothing goes on by itself
    assert worker.submit(PausePlan()).refusal == Refusal.NOTHING_TO_DO
    resumed = worker.submit(ResumePlan())
    assert resumed.accepted and "resumed at step 2" in resumed.message
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.SUCCEEDED, 15.0)
    final = worker.state().plan
    assert final.plan_id == paused.plan_id and [s.detail for s in final.steps] == [
        'said "one"',
        "waited 2 s",
        'said "done"',
    ]
    assert final.steps[1].sim_end_s - final.steps[1].sim_start_s >= 2.0  # the interrupted wait ran again in full
    assert worker.submit(ResumePlan()).refusal == Refusal.NOTHING_TO_DO


def test_a_new_command_discards_a_paused_plan(make_worker) -> None:
    worker = make_worker(realtime=True)
    first = worker.submit(ExecutePlan({"steps": [{"action": "wait", "seconds": 5}]}))
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.steps[0].state == StepState.RUNNING, 10.0)
    worker.submit(PausePlan())
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.PAUSED, 30.0)
    second = worker.submit(RunCommand("say hi"))
    assert worker.wait_for(succeeded(second.command_id), 10.0)
    assert first.command_id != second.command_id
    assert worker.submit(ResumePlan()).refusal == Refusal.NOTHING_TO_DO


def test_an_estop_with_a_pause_leaves_nothing_to_resume(make_worker) -> None:
    worker = make_worker(realtime=True)
    worker.submit(ExecutePlan({"steps": [{"action": "wait", "seconds": 5}, {"action": "say", "text": "later"}]}))
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.steps[0].state == StepState.RUNNING, 10.0)
    worker.submit(PausePlan())
    worker.submit(EStop(source="test"))
    assert worker.wait_for(lambda s: s.plan.state == PlanState.CANCELLED and s.estop_latched, 30.0)
    assert worker.submit(ResumePlan()).refusal == Refusal.ESTOP_LATCHED
    deadline = time.monotonic() + 30.0
    # the release is refused while the stop is still being applied (longer on a loaded machine)
    while not (released := worker.submit(ReleaseEStop(source="test"))).accepted and time.monotonic() < deadline:
        time.sleep(0.02)
    assert released.accepted, released.message
    assert worker.submit(ResumePlan()).refusal == Refusal.NOTHING_TO_DO


def test_a_misheard_command_asks_before_running_the_next_wording_the_recogniser_heard(make_worker) -> None:
    worker = make_worker(realtime=False)  # plans run unasked: the one of another wording still asks
    reply = worker.submit(RunCommand("please grant me the water bottle", ("please bring me the water bottle",)))
    assert reply.accepted and reply.message.startswith('did you mean "please bring me the water bottle"?'), reply
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == PlanState.AWAITING_APPROVAL, 30.0)
    plan = worker.state().plan
    assert plan.command_text == "please bring me the water bottle"
    assert ("pick_object", "blue bottle") in [(s.action, s.args.get("object")) for s in plan.steps]
    assert any(e.kind == "plan/heard_as" for e in worker.recent_events())
    assert worker.submit(CancelPlan()).accepted

    # a wording it can read is planned as heard; one it cannot, with nothing readable beside it, is refused
    said = worker.submit(RunCommand("say hello", ("say yellow",)))
    assert said.accepted and "queued" in said.message
    assert worker.wait_for(succeeded(said.command_id), 10.0)
    assert worker.state().plan.steps[0].detail == 'said "hello"'
    refused = worker.submit(RunCommand("bring me a beer", ("bring me a bear", "bring me a pier")))
    assert not refused.accepted and "unknown object 'beer'" in refused.message
