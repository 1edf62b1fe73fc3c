"""`pick_object`: where the robot stands to grasp, what is in reach, and the real grasp in physics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.interface import ExecutePlan, PlanState
from robot.manipulation.grasp_plan import GRASP_OFFSET, comfortably_in_reach, grasp_stance, reach_problem
from robot.model.scene import object_body_name
from robot.model.world import generate_world
from robot.sim.backend import MujocoSimBackend
from robot.worker import RobotWorker


@pytest.mark.parametrize("yaw", [0.0, math.pi / 2, -2.5])
def test_the_grasp_stance_puts_the_object_ahead_and_to_the_right_of_the_feet(yaw: float) -> None:
    stance = grasp_stance((1.6, 0.7), yaw)
    dx, dy = 1.6 - stance.x, 0.7 - stance.y
    c, s = math.cos(yaw), math.sin(yaw)
    ahead, left = c * dx + s * dy, -s * dx + c * dy
    assert (ahead, left) == pytest.approx(GRASP_OFFSET, abs=1e-9)
    assert stance.yaw == yaw


def test_a_stop_is_good_for_a_grasp_only_with_the_object_well_inside_the_reach() -> None:
    assert comfortably_in_reach(np.array([0.31, -0.11, 0.25]))
    assert reach_problem(np.array([0.34, -0.11, 0.25])) is None  # in reach, but a fresh sighting 1 cm off is not
    assert not comfortably_in_reach(np.array([0.34, -0.11, 0.25]))
    assert not comfortably_in_reach(np.array([0.31, -0.035, 0.25]))
    assert not comfortably_in_reach(np.array([0.31, -0.11, 0.60]))


def test_reach_says_what_is_out_of_reach() -> None:
    assert reach_problem(np.array([0.31, -0.11, 0.25])) is None
    assert "ahead" in reach_problem(np.array([0.50, -0.11, 0.25]))
    assert "side" in reach_problem(np.array([0.31, 0.10, 0.25]))
    assert "high" in reach_problem(np.array([0.31, -0.11, 0.60]))


def _run(worker: RobotWorker, steps: list[dict], timeout_s: float):
    """Run a plan to its end; the state then."""
    before = worker.state().plan
    reply = worker.submit(ExecutePlan({"steps": steps}))
    assert reply.accepted, reply
    earlier = before.plan_id if before is not None else None
    assert worker.wait_for(
        lambda s: s.plan is not None and s.plan.plan_id != earlier and s.plan.state != PlanState.RUNNING, timeout_s
    )
    state = worker.state()
    assert state.plan.state == PlanState.SUCCEEDED, [s.detail for s in state.plan.steps]
    return state


@pytest.mark.slow
def test_the_mug_is_found_at_the_counter_then_picked_with_contacts_and_held_up_in_the_hand() -> None:
    """The capstone in physics, checked against the simulator's truth (the mug's body is free: nothing welds or
    attaches it). First from the start, through the doorway, to the approach pose at the counter (planned on the
    lidar's map, steered by the robot's own pose estimate) and the mug found close by; then picked, after which the
    robot has stood up with it and brought it in close for carrying. (One walk for both: each costs a minute.)"""
    layout = generate_world(0)
    backend = MujocoSimBackend(layout)
    worker = RobotWorker(layout, backend=backend, realtime=False)
    worker.start()
    try:
        found = [
            {"action": "navigate_to", "args": {"target": "counter"}},  # an alias of the kitchen counter
            {"action": "detect_object", "args": {"object": "red mug"}},
        ]
        state = _run(worker, found, 400)
        assert "at the kitchen counter" in state.plan.steps[0].detail
        assert "found red mug at" in state.plan.steps[1].detail
        arrived = next(e for e in worker.recent_events() if e.kind == "navigation/arrived")
        approach = next(p for p in layout.places if p.name == "kitchen counter").approach
        assert arrived.data["error_m"] < 0.08  # by its own estimate (2 cm when it stops, plus what stopping adds)
        assert not state.fallen
        assert any(abs(x - 0.4) < 0.3 and abs(y) < 0.4 for x, y in arrived.data["path"])  # through the doorway
        # where it really stopped (the search only turned the head): its estimate was good to a few centimetres
        assert math.dist(state.base_position[:2], approach[:2]) < 0.06

        state = _run(worker, [{"action": "pick_object", "args": {"object": "red mug"}}], 600)
        assert "holding the red mug" in state.plan.steps[0].detail
        assert state.held_object == "red mug" and not state.fallen
        counter = next(p for p in layout.places if p.name == "kitchen counter").surface
        mug = backend.data.body(object_body_name("red mug")).xpos
        hand = backend.data.site("right_hand").xpos
        assert math.dist(mug[:2], hand[:2]) < 0.03  # between the fingers
        assert mug[2] > counter.height + 0.04  # lifted clear of the counter
        trunk = backend.data.qpos[:2]
        assert math.dist(mug[:2], trunk) < 0.30  # and held in close to the body, ready to walk
        picked = next(e for e in worker.recent_events() if e.kind == "manipulation/picked")
        assert picked.data["rise_m"] > 0.03
    finally:
        worker.stop()
