"""A place on a mat (the dock's 3 mm pad) is walked onto straight along its approach heading, from beyond the mat's
edge: a path that ended on the mat came at it aslant, a foot landed on the pad's corner and the robot, its arms held
back, fell backwards."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
import pytest

from robot.interface import ExecutePlan, PlanState, StepState
from robot.model.world import DOCK_PAD, FEET_REACH_M, ROBOT_RADIUS, Box, generate_world, near_mat_edges
from robot.navigation.costmap import Costmap
from robot.navigation.grid_planner import inflate
from robot.navigation.navigator import plan_path
from robot.sim.backend import MujocoSimBackend
from robot.skills.navigate import (
    MAT_EDGE_KEEP_OFF_M,
    MAT_ENTRY_M,
    HeldWay,
    entry_along,
    mat_entry,
    mat_under,
    pose_entries,
    roomiest_ways,
)
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


def test_a_pose_on_or_beside_a_mat_is_found_on_it_and_one_clear_of_it_is_not() -> None:
    layout = generate_world(2)
    assert mat_under(layout, DOCK_PAD.x, DOCK_PAD.y) == DOCK_PAD
    beside = DOCK_PAD.x + DOCK_PAD.half_x + FEET_REACH_M - 0.01  # a foot would land on the pad's edge
    assert mat_under(layout, beside, DOCK_PAD.y) == DOCK_PAD
    assert mat_under(layout, beside + 0.05, DOCK_PAD.y) is None


@pytest.mark.parametrize("yaw_deg", [90.0, 30.0])
def test_a_pose_with_a_heading_is_entered_in_line_with_it_from_ahead_or_from_behind(yaw_deg: float) -> None:
    yaw = math.radians(yaw_deg)
    pose = (DOCK_PAD.x + 0.03, DOCK_PAD.y - 0.04)
    (ahead, ahead_heading), (behind, behind_heading) = pose_entries(DOCK_PAD, *pose, yaw)
    assert ahead_heading == behind_heading == yaw  # the robot keeps the pose's heading onto it, both ways
    assert math.atan2(ahead[1] - pose[1], ahead[0] - pose[0]) == pytest.approx(yaw, abs=0.01)
    assert math.atan2(pose[1] - behind[1], pose[0] - behind[0]) == pytest.approx(yaw, abs=0.01)
    assert _beyond_edge(ahead) > 0.0 and _beyond_edge(behind) > 0.0


def test_a_pose_without_a_heading_can_be_entered_squarely_across_each_edge() -> None:
    pose = (DOCK_PAD.x - 0.02, DOCK_PAD.y + 0.05)
    ways = pose_entries(DOCK_PAD, *pose, None)
    assert sorted(round(math.degrees(h)) % 360 for _, h in ways) == [0, 90, 180, 270]
    for entry, heading in ways:  # walking forwards onto the pose, across an edge at right angles
        assert math.atan2(pose[1] - entry[1], pose[0] - entry[0]) == pytest.approx(heading, abs=0.01)
        back = _step(entry, heading, MAT_ENTRY_M)
        assert _beyond_edge(back) == pytest.approx(0.0, abs=2e-3) and _beyond_edge(entry) > MAT_ENTRY_M - 0.01


def test_a_path_past_the_pad_keeps_the_feet_off_its_edge() -> None:
    """From east of the pad to north of it, the shortest way hugs the pad's corner; the path keeps the feet clear."""
    room = Costmap(np.zeros((80, 60), dtype=bool), -2.0, -1.5, 0.05)
    costmap = room.also_blocked(near_mat_edges([DOCK_PAD], *room.centres(), MAT_EDGE_KEEP_OFF_M))
    assert not costmap.blocked_at(*mat_entry(_dock()))  # where the walk onto the pad starts stays open
    path = plan_path(costmap, (-1.1, -1.2), (-1.7, -0.7))
    along = [p for a, b in itertools.pairwise(path) for p in np.linspace(a, b, 20)]
    assert min(_beyond_edge(tuple(p)) for p in along) >= FEET_REACH_M
    assert not any(costmap.blocked_at(*p) for p in along)


def _grown_room(*boxes: Box):
    """A room with `boxes` in it, as the map grown by the footprint and a margin is (`roomiest_ways`' argument)."""
    room = Costmap(np.zeros((400, 300), dtype=bool), -2.0, -1.5, 0.01)  # fine cells: room measured to the cm
    xs, ys = room.centres()
    occupied = np.zeros_like(room.blocked)
    for box in boxes:
        occupied |= (np.abs(xs - box.x) <= box.half_x) & (np.abs(ys - box.y) <= box.half_y)
    return lambda extra_m: Costmap(inflate(occupied, (ROBOT_RADIUS + extra_m) / 0.01), -2.0, -1.5, 0.01)


def test_the_way_off_the_pad_with_room_is_taken_over_one_that_passes_a_box_at_the_footprints_width() -> None:
    """World 14: the way off east ran 16 cm from a box beside it, and a shoulder touched the box; north is open."""
    on_pad = (DOCK_PAD.x, DOCK_PAD.y)
    east, north = (entry_along(DOCK_PAD, *on_pad, 0.0), 0.0), (entry_along(DOCK_PAD, *on_pad, math.pi / 2), math.pi / 2)
    beside_east = Box("box", east[0][0] - 0.05, east[0][1] + ROBOT_RADIUS + 0.08, 0.1, 0.07, 0.3)
    assert roomiest_ways(_grown_room(beside_east), on_pad, [east, north]) == [north]
    assert roomiest_ways(_grown_room(), on_pad, [east, north]) == [east, north]  # both open: the order kept


def test_the_way_onto_the_pad_follows_the_map_on_the_walk_there_and_is_held_near_its_entry() -> None:
    """The navigator walks straight from the path's end onto the way it is given there: a way changed at the entry
    is not walked straight (it is walked on a planned path after the navigator's walk)."""
    north, east = ((0.0, 1.0), (0.0, 0.5, math.pi / 2)), ((1.0, 0.0), (0.5, 0.0, 0.0))
    shown, here = [north], [(3.0, 3.0)]
    way = HeldWay(lambda: shown[0], lambda: here[0])
    assert way() == north
    shown[0] = east  # the map grew: the north way is blocked
    assert way() == east  # far from the entry: the way as the map now shows it
    here[0] = (1.1, 0.1)  # at the east entry
    shown[0] = north
    assert way() == east  # held
    here[0] = (2.0, 2.0)  # walked away from it (a replan)
    assert way() == north


def test_where_no_way_has_the_usual_room_the_ways_the_footprint_clears_are_kept() -> None:
    on_pad = (DOCK_PAD.x, DOCK_PAD.y)
    east, north = (entry_along(DOCK_PAD, *on_pad, 0.0), 0.0), (entry_along(DOCK_PAD, *on_pad, math.pi / 2), math.pi / 2)
    beside_east = Box("box", east[0][0] - 0.05, east[0][1] + ROBOT_RADIUS + 0.09, 0.1, 0.07, 0.3)  # 2 cm to spare
    across_north = Box("wall", north[0][0], north[0][1] + 0.1, 0.5, 0.05, 0.3)
    assert roomiest_ways(_grown_room(beside_east, across_north), on_pad, [north, east]) == [east]
    assert roomiest_ways(lambda _extra: None, on_pad, [north, east]) == [north, east]  # no map yet


def _walk_near_the_pad(seed: int, *targets: str):
    """Walk to each of `targets` in turn on world `seed`; the final state, and where the robot was (x, y, estimated
    yaw) while off the pad with a foot within reach of its edge, on the way to the last."""
    layout = generate_world(seed)
    worker = RobotWorker(layout, backend=MujocoSimBackend(layout), realtime=False)
    worker.start()
    near_pad: list[tuple[float, float, float]] = []

    def ended(state) -> bool:
        last = state.plan is not None and state.plan.steps[-1].state == StepState.RUNNING
        if last and 0.0 < _beyond_edge(state.base_position[:2]) < FEET_REACH_M:  # off the pad, a foot near it
            near_pad.append((*state.base_position[:2], state.locomotion.estimated_pose[2]))
        return state.plan is not None and state.plan.state != PlanState.RUNNING

    try:
        steps = [{"action": "navigate_to", "args": {"target": target}} for target in targets]
        assert worker.submit(ExecutePlan({"steps": steps})).accepted
        assert worker.wait_for(ended, 400)
        return worker.state(), near_pad
    finally:
        worker.stop()


def test_the_robot_walks_onto_the_dock_squarely_and_stands_on_it() -> None:
    """World 2: the path from the start comes at the pad from its north-east corner; the robot must only come near
    the pad (a foot within reach of its edge) in line with the dock's heading, turned to it (walking on from the
    path without a stop, it came onto the pad 30-40 degrees aslant)."""
    dock = _dock(2)
    state, near_pad = _walk_near_the_pad(2, "charging dock")
    assert state.plan.state == PlanState.SUCCEEDED, state.plan.steps[0].detail
    assert not state.fallen
    assert math.dist(state.base_position[:2], dock.approach[:2]) < 0.1  # the truth: on the pad
    assert near_pad
    # near the pad, only on its side facing the room and in line with the dock, never by its corners
    east_edge = DOCK_PAD.x + DOCK_PAD.half_x
    assert all(x > east_edge and abs(y - dock.approach[1]) < 0.08 for x, y, _ in near_pad), near_pad
    assert all(abs(math.degrees(yaw)) < 12.0 for *_, yaw in near_pad), near_pad


def test_a_box_on_the_docks_own_entry_has_the_robot_walk_onto_the_pad_across_another_edge() -> None:
    """World 22: a box stands where the walk onto the dock along its heading starts (a tour walked into it and fell);
    the robot comes onto the pad squarely from the north, the way with room."""
    layout = generate_world(22)
    box = next(b for b in layout.obstacles if b.name == "box_2")
    assert box.contains(*mat_entry(_dock(22)))  # the dock's own way on is taken by the box
    state, near_pad = _walk_near_the_pad(22, "charging dock")
    assert state.plan.state == PlanState.SUCCEEDED, state.plan.steps[0].detail
    assert not state.fallen
    assert math.dist(state.base_position[:2], _dock(22).approach[:2]) < 0.1  # the truth: on the pad
    north_edge = DOCK_PAD.y + DOCK_PAD.half_y
    assert near_pad and all(y > north_edge and abs(x - DOCK_PAD.x) < 0.08 for x, y, _ in near_pad), near_pad
    assert all(abs(math.degrees(yaw) + 90.0) < 12.0 for *_, yaw in near_pad), near_pad  # facing the pad, south


def test_a_pose_typed_on_the_dock_is_walked_onto_squarely_along_its_heading() -> None:
    """A pose on the pad facing north (+y), typed rather than the place: the robot comes onto the pad from the
    north (south of it is the wall), in line with the pose and turned to its heading, as for the place (a foot landing
    on the pad's edge tipped the robot over with its arms held back: stop 65's fresh-clone CI)."""
    target = f"{DOCK_PAD.x:.2f}, {DOCK_PAD.y:.2f}, 90 deg"
    state, near_pad = _walk_near_the_pad(2, target)
    assert state.plan.state == PlanState.SUCCEEDED, state.plan.steps[0].detail
    assert not state.fallen
    assert math.dist(state.base_position[:2], (DOCK_PAD.x, DOCK_PAD.y)) < 0.1
    assert near_pad
    north_edge = DOCK_PAD.y + DOCK_PAD.half_y
    assert all(y > north_edge and abs(x - DOCK_PAD.x) < 0.08 for x, y, _ in near_pad), near_pad
    assert all(abs(math.degrees(yaw) - 90.0) < 12.0 for *_, yaw in near_pad), near_pad


def test_the_robot_walks_off_the_dock_squarely_the_way_it_faces() -> None:
    """World 2, from the dock to the kitchen counter (across the room, north-east): setting off along its path, the
    robot turned on the pad towards the counter and walked off over the pad's edge aslant (tours fell leaving the
    dock). It walks off ahead, over the edge it faces, in line and turned to it, never by the pad's corners."""
    dock = _dock(2)
    state, near_pad = _walk_near_the_pad(2, "charging dock", "kitchen counter")
    assert state.plan.state == PlanState.SUCCEEDED, [step.detail for step in state.plan.steps]
    assert not state.fallen
    assert near_pad
    east_edge = DOCK_PAD.x + DOCK_PAD.half_x
    assert all(x > east_edge and abs(y - dock.approach[1]) < 0.08 for x, y, _ in near_pad), near_pad
    assert all(abs(math.degrees(yaw)) < 12.0 for *_, yaw in near_pad), near_pad
