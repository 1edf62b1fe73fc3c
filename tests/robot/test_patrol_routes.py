"""Where a patrol passes each place: open floor with room to turn, and never with the feet across a mat's edge
(the dock's pad, where a robot turning with one foot on it and one off rocks and may fall)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from robot.behaviours.routes import WAYPOINT_SHIFT_M, waypoint_near
from robot.model.world import DOCK_PAD, FEET_REACH_M, generate_world


def _distance_to_edge(point: tuple[float, float]) -> float:
    """How far the point is from the dock pad's edge, inside or out."""
    dx, dy = abs(point[0] - DOCK_PAD.x) - DOCK_PAD.half_x, abs(point[1] - DOCK_PAD.y) - DOCK_PAD.half_y
    if dx <= 0 and dy <= 0:
        return -max(dx, dy)
    return math.hypot(max(dx, 0.0), max(dy, 0.0))


@pytest.mark.parametrize("seed", [0, 1, 5, 100, 105, 123])
def test_the_docks_waypoint_keeps_the_feet_off_the_pads_edge_and_stays_near_the_dock(seed: int) -> None:
    layout = generate_world(seed)
    dock = next(p for p in layout.places if p.name == "charging dock")
    point = waypoint_near(layout, dock.staging)
    assert _distance_to_edge(point) >= FEET_REACH_M - 1e-9
    assert math.dist(point, dock.staging) <= WAYPOINT_SHIFT_M


def test_a_waypoint_away_from_any_mat_is_where_it_was() -> None:
    """Only the waypoints near a mat move: the others are where the walls and furniture alone put them."""
    layout = generate_world(0)
    without_mats = replace(layout, furniture=tuple(box for box in layout.furniture if box.name != DOCK_PAD.name))
    for place in layout.places:
        moved = waypoint_near(layout, place.staging) != waypoint_near(without_mats, place.staging)
        assert moved == (place.name == "charging dock")
