"""A place on a mat (the dock's 3 mm pad) is walked onto straight along its approach heading, from beyond the mat's
edge: a path that ended on the mat came at it aslant and a foot landed on the pad's corner (the robot, its arms held
back as tried at stop 64, then fell backwards)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from robot.behaviours.routes import FEET_REACH_M
from robot.interface import ExecutePlan, PlanState
from robot.model.world import DOCK_PAD, generate_world
from robot.sim.backend import MujocoSimBackend
from robot.skills.navigate import MAT_ENTRY_M, mat_entry
from robot.worker import RobotWorker


def _dock(seed: int = 2):
    return next(p for p in generate_world(seed).places if p.name == "charging dock")


def _beyond_edge(point: tuple[float, float]) -> float:
    """How far `point` is outside the dock pad (0 on or inside it)."""
    dx, dy = abs(point[0] - DOCK_PAD.x) - DOCK_PAD.half_x, abs(point[1] - DOCK_PAD.y) - DOCK_PAD.half_y
    return math.hypot(max(dx, 0.0), max(dy, 0.0))


def _step(point: tuple[float, float], yaw: float, distance: float) -> tuple[float, float]:
    return point[0] + distance * math.cos(yaw), point[1] + distance * math.sin(yaw)


def test_the_walk_onto_the_dock_starts_in_line_with_its_heading_beyond_the_pads_edge() -> None:
    dock = _dock()
    x, y = mat_entry(dock)
    assert dock.approach[2] == 0.0  # the dock faces into the room (+x)
    assert y == dock.approach[1]  # in line: the robot walks straight back onto the pad
    assert x == pytest.approx(DOCK_PAD.x + DOCK_PAD.half_x + MAT_ENTRY_M)


def test_a_pose_turned_on_the_mat_is_entered_along_its_own_heading() -> None:
    yaw = math.pi / 4
    dock = replace(_dock(), approach=(DOCK_PAD.x + 0.05, DOCK_PAD.y - 0.02, yaw))
    x, y = mat_entry(dock)
    along = (x - dock.approach[0], y - dock.approach[1])
    assert math.atan2(along[1], along[0]) == pytest.approx(yaw, abs=0.01)
    assert _beyond_edge((x, y)) > 0.0  # off the pad, MAT_ENTRY_M along the heading beyond the edge it leaves by
    back = (x - MAT_ENTRY_M * math.cos(yaw), y - MAT_ENTRY_M * math.sin(yaw))
    assert _beyond_edge(back) == pytest.approx(0.0, abs=2e-3) and _beyond_edge(_step(back, yaw, 0.01)) > 0.0


def test_the_robot_walks_onto_the_dock_squarely_and_stands_on_it() -> None:
    """World 2: the path from the start comes at the pad from its north-east corner; the robot must only come near
    the pad (a foot within reach of its edge) in line with the dock's heading, turned to it (walking on from the
    path without a stop, it came onto the pad 30-40 degrees aslant)."""
    layout = generate_world(2)
    dock = next(p for p in layout.places if p.name == "charging dock")
    worker = RobotWorker(layout, backend=MujocoSimBackend(layout), realtime=False)
    worker.start()
    near_pad: list[tuple[float, float, float]] = []

    def ended(state) -> bool:
        if 0.0 < _beyond_edge(state.base_position[:2]) < FEET_REACH_M:  # off the pad, a foot within reach of it
            near_pad.append((*state.base_position[:2], state.locomotion.estimated_pose[2]))
        return state.plan is not None and state.plan.state != PlanState.RUNNING

    try:
        steps = [{"action": "navigate_to", "args": {"target": "charging dock"}}]
        assert worker.submit(ExecutePlan({"steps": steps})).accepted
        assert worker.wait_for(ended, 400)
        state = worker.state()
        assert state.plan.state == PlanState.SUCCEEDED, state.plan.steps[0].detail
        assert not state.fallen
        assert math.dist(state.base_position[:2], dock.approach[:2]) < 0.1  # the truth: on the pad
        assert near_pad
        # near the pad, only on its side facing the room and in line with the dock, never by its corners
        east_edge = DOCK_PAD.x + DOCK_PAD.half_x
        assert all(x > east_edge and abs(y - dock.approach[1]) < 0.08 for x, y, _ in near_pad), near_pad
        assert all(abs(math.degrees(yaw)) < 12.0 for *_, yaw in near_pad), near_pad
    finally:
        worker.stop()
