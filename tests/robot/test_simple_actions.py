"""The extra actions on the whole simulated robot: each does what it says, in physics."""

from __future__ import annotations

import dataclasses
import math

from robot.interface import ExecutePlan, KnownObject, PlanState, RunCommand
from robot.model.world import generate_world
from robot.sim.backend import MujocoSimBackend
from robot.skills.simple import describe
from robot.worker import RobotWorker


def _run(worker: RobotWorker, reply, timeout_s: float = 240.0):
    assert reply.accepted, reply
    assert worker.wait_for(
        lambda s: s.plan is not None and s.plan.command_id == reply.command_id and s.plan.state != PlanState.RUNNING,
        timeout_s,
    )
    return worker.state()


def test_what_do_you_see_looks_all_round_and_says_what_is_there() -> None:
    base = generate_world(0)
    apple = next(o for o in base.objects if o.name == "green apple").position
    x, y = 0.9, -0.3  # in the kitchen, the counter behind the robot
    away = math.atan2(apple[1] - y, apple[0] - x) + math.pi
    layout = dataclasses.replace(base, robot_start=(x, y, away))
    worker = RobotWorker(layout, backend=MujocoSimBackend(layout), realtime=False, max_auto_replans=0)
    worker.start()
    try:
        subscription = worker.subscribe()
        state = _run(worker, worker.submit(RunCommand("what do you see?")))
        look, tell = state.plan.steps
        assert state.plan.state == PlanState.SUCCEEDED, look.detail + tell.detail
        assert "over a full turn: saw" in look.detail and "green apple" in look.detail
        assert {"green apple", "red mug"} <= {k.name for k in state.perception.known_objects}
        said = []
        while (event := subscription.get(timeout=0.05)) is not None:
            if event.kind == "speech/say":
                said.append(event.message)
        assert any("the green apple on the kitchen counter" in s for s in said), said
        # it ends facing the way it started, standing
        assert abs(math.remainder(state.base_yaw_rad - away, math.tau)) < math.radians(25)
        assert not state.fallen
    finally:
        worker.stop()


def test_wait_takes_its_seconds_of_simulated_time(make_worker) -> None:
    worker = make_worker(realtime=False)
    state = _run(worker, worker.submit(RunCommand("wait for three seconds")), 30.0)
    step = state.plan.steps[0]
    assert state.plan.state == PlanState.SUCCEEDED
    assert 3.0 <= step.sim_end_s - step.sim_start_s < 3.2


def test_go_home_walks_back_to_the_start_pose(make_worker) -> None:
    worker = make_worker(realtime=False, perception=True, max_auto_replans=0)
    home = worker.layout.robot_start
    plan = {
        "steps": [
            {"action": "navigate_to", "target": f"{home[0] + 0.6:.2f}, {home[1] + 0.3:.2f}"},
            {"action": "go_home"},
        ]
    }
    state = _run(worker, worker.submit(ExecutePlan(plan)))
    assert state.plan.state == PlanState.SUCCEEDED, [s.detail for s in state.plan.steps]
    assert state.plan.steps[1].detail.startswith("home: at ")
    assert math.dist(state.base_position[:2], home[:2]) < 0.12
    assert abs(math.remainder(state.base_yaw_rad - home[2], math.tau)) < math.radians(15)


def test_stop_replaces_a_walk_and_leaves_the_robot_standing_short_of_the_goal(make_worker) -> None:
    worker = make_worker(realtime=False, perception=True, max_auto_replans=0)
    home = worker.layout.robot_start
    goal = (home[0] + 1.2, home[1])
    walk = worker.submit(ExecutePlan({"steps": [{"action": "navigate_to", "target": f"{goal[0]:.2f}, {goal[1]:.2f}"}]}))
    assert worker.wait_for(lambda s: s.locomotion is not None and s.locomotion.phase == "walking", 60.0)
    assert worker.wait_for(lambda s: math.dist(s.base_position[:2], home[:2]) > 0.15, 60.0)
    state = _run(worker, worker.submit(RunCommand("stop")), 60.0)
    assert state.plan.state == PlanState.SUCCEEDED and state.plan.command_id != walk.command_id
    assert state.plan.steps[0].detail.startswith("stopped: standing still")
    assert state.locomotion.phase == "standing"
    assert math.dist(state.base_position[:2], goal) > 0.5
    assert not state.fallen


def test_the_description_names_the_nearest_first_and_says_when_nothing_is_known() -> None:
    mug = KnownObject("red mug", (1.6, 0.0, 0.25), "kitchen counter", 1.0, 0.9)
    apple = KnownObject("green apple", (0.5, 0.0, 0.0), "floor", 1.0, 0.9)
    assert describe((mug, apple), (0.0, 0.0)) == (
        "I see the green apple on the floor, 0.5 metres away and the red mug on the kitchen counter, 1.6 metres away."
    )
    assert describe((), (0.0, 0.0)) == "I have not seen any of the objects I know."
