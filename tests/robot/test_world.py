from __future__ import annotations

import math

import pytest

from robot.model.world import (
    KITCHEN_COUNTER,
    NAV_CLEARANCE_M,
    ROBOT_RADIUS,
    Box,
    generate_world,
    occupancy_grid,
    reachable,
)


def test_same_seed_same_world_and_different_seeds_differ() -> None:
    assert generate_world(7) == generate_world(7)
    placements = {tuple(o.position for o in generate_world(s).objects) for s in range(10)}
    obstacles = {tuple((b.x, b.y) for b in generate_world(s).obstacles) for s in range(10)}
    assert len(placements) == 10
    assert len(obstacles) == 10


@pytest.mark.parametrize("seed", range(40))
def test_every_seed_is_solvable(seed: int) -> None:
    world = generate_world(seed)
    assert {"kitchen counter", "living-room table", "charging dock"} <= set(world.place_names)
    assert {"red mug", "blue bottle", "green apple"} <= set(world.object_names)
    assert len(world.obstacles) >= 3
    # by the navigator's rules: its map grows every obstacle by the footprint and a clearance
    assert reachable(world, [p.staging for p in world.places], ROBOT_RADIUS + NAV_CLEARANCE_M)


@pytest.mark.parametrize("seed", range(10))
def test_objects_stand_on_the_counter_within_reach_of_its_front(seed: int) -> None:
    front = KITCHEN_COUNTER.x - KITCHEN_COUNTER.half_x
    for obj in generate_world(seed).objects:
        x, y, z = obj.position
        assert obj.place == "kitchen counter"
        assert z == pytest.approx(KITCHEN_COUNTER.height)
        assert 0.05 <= x - front <= 0.13
        assert abs(y - KITCHEN_COUNTER.y) <= KITCHEN_COUNTER.half_y


def test_a_walled_in_goal_is_reported_unreachable() -> None:
    world = generate_world(0)
    grid, _, _ = occupancy_grid(world)
    assert grid.any() and not grid.all()
    # The inside of the counter is blocked for the robot's centre.
    assert not reachable(world, [(KITCHEN_COUNTER.x, KITCHEN_COUNTER.y)])


def test_negative_seed_is_refused() -> None:
    with pytest.raises(ValueError, match="seed"):
        generate_world(-1)


def test_a_box_is_found_ahead_at_its_near_edge_and_missed_when_looking_away() -> None:
    counter = Box("counter", x=1.75, y=0.55, half_x=0.2, half_y=0.7, height=0.25)
    assert counter.distance_along(1.3, 0.7, 0.0) == pytest.approx(0.25)
    assert counter.distance_along(1.3, 0.7, math.pi) == math.inf
    assert counter.distance_along(1.75, -0.5, math.pi / 2) == pytest.approx(0.35)
    assert counter.distance_along(1.75, 0.5, 1.0) == 0.0  # standing inside it (in plan view)
