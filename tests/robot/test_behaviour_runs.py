"""Behaviours on a simulated robot (perception off: these behaviours only stand, wait and gesture): they exclude
plans and teleop as a plan does, pause and resume from their state, end on the e-stop, and a user's exception or
a step that overruns its timeout ends the behaviour with the reason and leaves the robot standing, arm stowed."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

import robot.robot as robot_module
from robot.behaviours.api import Behaviour, Param
from robot.behaviours.errors import BehaviourFailed
from robot.behaviours.registry import Registry
from robot.interface import (
    BehaviourState,
    CancelPlan,
    EStop,
    Fault,
    InjectFault,
    PauseBehaviour,
    Refusal,
    ReleaseEStop,
    ResumeBehaviour,
    RunCommand,
    StartBehaviour,
    StopBehaviour,
    Teleop,
)
from robot.model import humanoid_v1


class Count(Behaviour):
    """Counts in simulated time, one state per tick of its counter: visible states, feedback and progress."""

    name = "count"
    description = "count to a number, a second a step"
    parameters = (Param("to", int, 3, minimum=1),)
    states = ("counting", "done")

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.count = 0
        self.calls: list[str] = []

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        self.calls.append(state)
        if state == "done":
            robot.say(f"counted to {self.count}")
            return None
        robot.wait(0.5)
        self.count += 1
        robot.feedback(f"{self.count}")
        robot.progress(self.count / self.params["to"])
        return "done" if self.count >= self.params["to"] else "counting"


class Crash(Behaviour):
    name = "crash"
    description = "raises in its step after raising the arm"
    states = ("waving",)

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        robot.feedback("about to fail")
        raise ValueError("user bug")


class Quit(Behaviour):
    name = "quit"
    description = "calls sys.exit in its step"
    states = ("quitting",)

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        raise SystemExit(3)


class Hang(Behaviour):
    name = "hang"
    description = "a step that never returns (and never asks the robot anything)"
    states = ("stuck",)
    step_timeout_s = 1.0

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        while True:
            time.sleep(0.01)


class Wave(Behaviour):
    name = "wave"
    description = "waves until stopped"
    states = ("waving",)

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        robot.gesture("wave")
        return "waving"


class Stroll(Behaviour):
    """Walks to a pose (perception is off in these tests, so the walk itself fails, said in its feedback)."""

    name = "stroll"
    description = "walks to a pose"
    states = ("walking",)
    step_timeout_s = 60.0  # shorter than a rest for a hot servo, which is the robot's time, not the step's

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        try:
            robot.go_to("0.0, 0.0")
        except BehaviourFailed as exc:
            robot.feedback(f"no walk: {exc}")
        return None


@pytest.fixture
def registry(monkeypatch: pytest.MonkeyPatch) -> Registry:
    found = Registry({b.name: b for b in (Count, Crash, Quit, Hang, Wave, Stroll)}, {}, {})
    monkeypatch.setattr(robot_module, "discover", lambda: found)
    return found


def behaviour_is(state: BehaviourState):
    return lambda s: s.behaviour is not None and s.behaviour.state == state


def arm_down(worker) -> bool:  # type: ignore[no-untyped-def]
    joints = worker.body.latest().joint_positions
    stand = humanoid_v1.stand_posture()
    names = humanoid_v1.JOINT_NAMES
    return all(abs(joints[names.index(n)] - stand[n]) < 0.15 for n in ("r_sho_pitch", "r_sho_roll", "r_el"))


def test_a_behaviour_runs_its_states_with_feedback_and_progress(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    reply = worker.submit(StartBehaviour("count", {"to": "2"}))
    assert reply.accepted, reply.message
    assert worker.wait_for(behaviour_is(BehaviourState.SUCCEEDED), 60.0)
    status = worker.state().behaviour
    assert status.name == "count" and status.params == {"to": 2}
    assert status.feedback == ("1", "2") and status.progress == 1.0 and status.machine_state == "done"
    kinds = [e.kind for e in worker.recent_events() if e.kind.startswith("behaviour/")]
    assert kinds[0] == "behaviour/started" and kinds[-1] == "behaviour/finished"
    assert "behaviour/state" in kinds


def test_bad_names_and_parameters_are_refused_naming_them(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    unknown = worker.submit(StartBehaviour("dance"))
    assert unknown.refusal == Refusal.INVALID and "dance" in unknown.message
    negative = worker.submit(StartBehaviour("count", {"to": -2}))
    assert negative.refusal == Refusal.INVALID and "'to'" in negative.message
    wrong = worker.submit(StartBehaviour("count", {"to": "many"}))
    assert wrong.refusal == Refusal.INVALID and wrong.errors[0].startswith("to:")
    assert worker.state().behaviour is None


def test_a_running_behaviour_excludes_plans_teleop_and_another_behaviour(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("count", {"to": 50})).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.RUNNING), 20.0)
    plan = worker.submit(RunCommand("say hello"))
    assert plan.refusal == Refusal.BUSY and "count behaviour is running" in plan.message
    teleop = worker.submit(Teleop(0.1, 0.0, 0.0))
    assert teleop.refusal == Refusal.BUSY and "count behaviour is running" in teleop.message
    assert worker.submit(StartBehaviour("count")).refusal == Refusal.BUSY
    assert worker.submit(StopBehaviour()).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.STOPPED), 20.0)
    assert worker.state().behaviour.reason == "stopped by the operator"
    assert worker.submit(RunCommand("say hello")).accepted


def test_pause_keeps_the_state_and_resume_goes_on_from_it(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("count", {"to": 6})).accepted
    assert worker.wait_for(lambda s: s.behaviour is not None and len(s.behaviour.feedback) >= 2, 30.0)
    assert worker.submit(PauseBehaviour()).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.PAUSED), 20.0)
    paused_at = len(worker.state().behaviour.feedback)
    assert worker.submit(RunCommand("say hello")).refusal == Refusal.BUSY  # still the behaviour's turn
    assert worker.submit(ResumeBehaviour()).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.SUCCEEDED), 60.0)
    feedback = worker.state().behaviour.feedback
    assert feedback == tuple(str(n) for n in range(1, 7))  # counted on from where it was, not from the start
    assert len(feedback) > paused_at


def test_the_estop_ends_a_behaviour_and_holds(make_worker, registry) -> None:
    """The run's reason says who latched the stop, and why when it was not a person (a bench run that ended "stopped
    by the e-stop" with nothing touched left its cause unknown)."""
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("count", {"to": 50})).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.RUNNING), 20.0)
    worker.submit(EStop(source="diagnostics", reason="servos/r_knee: overload"))
    assert worker.wait_for(behaviour_is(BehaviourState.STOPPED), 20.0)
    state = worker.state()
    assert state.estop_latched
    assert state.behaviour.reason == "stopped by the e-stop (diagnostics: servos/r_knee: overload)"
    assert worker.submit(ResumeBehaviour()).refusal == Refusal.NOTHING_TO_DO
    assert worker.submit(StartBehaviour("count")).refusal == Refusal.ESTOP_LATCHED
    worker.submit(ReleaseEStop(source="test"))


def test_the_estop_ends_a_paused_behaviour_saying_who_latched_it(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("count", {"to": 50})).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.RUNNING), 20.0)
    assert worker.submit(PauseBehaviour()).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.PAUSED), 20.0)
    worker.submit(EStop(source="browser"))
    assert worker.wait_for(behaviour_is(BehaviourState.STOPPED), 20.0)
    assert worker.state().behaviour.reason == "stopped by the e-stop (browser)"
    worker.submit(ReleaseEStop(source="test"))


def test_a_paused_behaviour_cancelled_by_the_plan_controls_is_stopped(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("count", {"to": 50})).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.RUNNING), 20.0)
    assert worker.submit(PauseBehaviour()).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.PAUSED), 20.0)
    worker.submit(CancelPlan())
    assert worker.wait_for(behaviour_is(BehaviourState.STOPPED), 20.0)


def test_an_exception_in_user_code_ends_the_behaviour_with_the_reason(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("crash")).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.FAILED), 30.0)
    state = worker.state()
    assert "ValueError: user bug" in state.behaviour.reason
    assert not state.fallen and worker.is_alive()
    assert worker.submit(RunCommand("say hello")).accepted  # the robot takes commands again


def test_a_step_that_exits_ends_the_behaviour_not_the_robot(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("quit")).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.FAILED), 30.0)
    assert "SystemExit" in worker.state().behaviour.reason
    assert worker.is_alive() and worker.submit(StartBehaviour("count", {"to": 1})).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.SUCCEEDED), 30.0)


def test_a_step_that_overruns_its_timeout_ends_the_behaviour(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("hang")).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.FAILED), 60.0)
    assert "overran its step timeout of 1 s" in worker.state().behaviour.reason
    assert not worker.state().fallen


def test_stopping_mid_gesture_leaves_the_robot_standing_with_the_arm_stowed(make_worker, registry) -> None:
    worker = make_worker(realtime=False)
    assert worker.submit(StartBehaviour("wave")).accepted
    names = humanoid_v1.JOINT_NAMES
    assert worker.wait_for(
        lambda s: worker.arm.active and worker.body.latest().joint_positions[names.index("r_el")] < -0.8, 60.0
    )
    assert worker.submit(StopBehaviour()).accepted
    assert worker.wait_for(behaviour_is(BehaviourState.STOPPED), 60.0)
    assert not worker.arm.active
    assert worker.wait_for(lambda s: arm_down(worker), 30.0)
    assert not worker.state().fallen
    assert np.isfinite(worker.state().tilt_deg) and worker.state().tilt_deg < 20.0


def test_a_walk_waits_standing_for_a_hot_servo_to_cool_and_says_so(make_worker, registry) -> None:
    """A long patrol heated a knee to where the diagnostics stop the robot (75 C): a behaviour's walk starts only
    10 degrees below the warning (65 C), after a rest down to 50 C."""
    worker = make_worker(realtime=False)
    assert worker.submit(InjectFault(Fault.SERVO_HEAT, "l_knee", 33.0)).accepted  # about 58 C, below the warning
    assert worker.submit(StartBehaviour("stroll")).accepted
    assert worker.wait_for(lambda s: s.behaviour is not None and s.behaviour.state.finished, 300.0)
    state = worker.state()
    assert state.behaviour.state == BehaviourState.SUCCEEDED and not state.estop_latched
    resting, rested, walked = state.behaviour.feedback
    assert resting.startswith("resting: the l_knee servo is at 5") and resting.endswith("walking on below 50 C")
    rest = re.fullmatch(r"rested (\d+) s: the hottest servo is at (\d+) C", rested)
    assert rest is not None and int(rest[1]) > Stroll.step_timeout_s and int(rest[2]) <= 50  # (49.9 shows as 50)
    assert walked.startswith("no walk:")  # the walk was asked for only after the rest
