"""After placing, the arm finishes stowing while the plan goes on: a spoken confirmation need not wait for it, but a
step that moves the body does, and the plan ends with the arms down."""

from __future__ import annotations

import threading

import pytest

from robot.interface import ExecutePlan, PlanState, Posture, Refusal, SetPosture, StepState
from robot.model import humanoid_v1
from robot.planning.executor import ExecutionContext

ARM_JOINTS = ("r_sho_pitch", "r_sho_roll", "r_el")


def _arm_angles(worker) -> dict[str, float]:
    model, qpos = worker.backend.model, worker.state().qpos
    return {name: qpos[model.joint(name).qposadr[0]] for name in ARM_JOINTS}


def test_speech_overlaps_the_arm_finishing_and_a_body_step_waits_for_it(make_worker) -> None:
    worker = make_worker(realtime=False)
    assert worker.wait_for(lambda s: s.sim_time_s >= 0.5, 30.0)
    cancel = threading.Event()
    ctx = ExecutionContext(cancel=cancel, say=lambda text: None, wait_sim=lambda s: worker.runner.wait_sim(s, cancel))
    worker.skills.manipulate.arm_body(ctx).stow_arm(
        finish_in_background=True
    )  # as placing leaves it: swung back, still unfolding
    left_at = worker.state().sim_time_s
    assert max(abs(a - humanoid_v1.stand_posture()[n]) for n, a in _arm_angles(worker).items()) > 0.5

    busy = worker.submit(SetPosture(Posture.CROUCH))
    assert not busy.accepted and busy.refusal == Refusal.BUSY and "arm" in busy.message

    say_then_walk = [
        {"action": "say", "args": {"text": "done"}},
        {"action": "navigate_to", "args": {"target": "kitchen counter"}},
    ]
    reply = worker.submit(ExecutePlan({"steps": say_then_walk}))
    assert reply.accepted
    assert worker.wait_for(
        lambda s: s.plan is not None and s.plan.command_id == reply.command_id and s.plan.state != PlanState.RUNNING,
        60.0,
    )
    say, walk = worker.state().plan.steps
    assert say.state == StepState.SUCCEEDED and say.sim_end_s < left_at + 1.0  # spoken while the arm still moved
    # the walk waited for the arm's last two moves (0.8 s each) before it found it had no map to walk on
    assert walk.state == StepState.FAILED and "perception is off" in walk.detail
    assert walk.sim_end_s >= left_at + 1.6
    for name, angle in _arm_angles(worker).items():
        assert angle == pytest.approx(humanoid_v1.stand_posture()[name], abs=0.1), name
    assert worker.submit(SetPosture(Posture.CROUCH)).accepted  # the joints are the posture controller's again
