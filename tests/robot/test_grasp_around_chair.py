"""Where to stand to grasp when something stands where the feet usually go: turned a little, or from another side
of the surface (at world seed 0 a chair against the counter in front of the apple made the fetch give up)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.manipulation.grasp_plan import (
    grasp_stance,
    grasp_stance_facing_any,
    reach_problem,
    stance_facings,
    stance_taken,
)
from robot.model.world import Box, generate_world


def object_in_feet(stance, xy: tuple[float, float], z: float) -> np.ndarray:
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    dx, dy = xy[0] - stance.x, xy[1] - stance.y
    return np.array([c * dx + s * dy, -s * dx + c * dy, z])


def layout_map(layout):
    """The world's furniture, obstacles and walls as the lidar's map has them (no margin)."""
    boxes = [*layout.furniture, *layout.obstacles, *layout.walls]
    return lambda x, y: any(b.contains(x, y) for b in boxes)


def at_the_counter(seed: int, name: str):
    """World `seed`'s kitchen counter, where the object `name` stands on it, and the world's map."""
    layout = generate_world(seed)
    counter = next(p for p in layout.places if p.name == "kitchen counter")
    thing = next(o for o in layout.objects if o.name == name)
    return counter, (float(thing.position[0]), float(thing.position[1])), layout_map(layout)


def test_a_chair_where_the_feet_go_moves_the_stance_to_a_free_one_with_the_object_still_in_reach() -> None:
    counter, xy, blocked = at_the_counter(0, "green apple")
    assert stance_taken(grasp_stance(xy, counter.approach[2], blocked), blocked)  # the chair

    stance = grasp_stance_facing_any(xy, stance_facings(counter.approach[2], counter.surface, xy), blocked)
    assert not stance_taken(stance, blocked)
    assert reach_problem(object_in_feet(stance, xy, counter.surface.height)) is None
    assert not counter.surface.contains(stance.x, stance.y, margin=0.05)


def test_a_stance_that_is_free_is_kept_as_it_was() -> None:
    counter, xy, blocked = at_the_counter(0, "red mug")
    facings = stance_facings(counter.approach[2], counter.surface, xy)
    assert grasp_stance_facing_any(xy, facings, blocked) == grasp_stance(xy, counter.approach[2], blocked)
    # nothing free anywhere: the usual stance, for the caller to say there is no room
    everywhere = lambda x, y: True  # noqa: E731
    assert grasp_stance_facing_any(xy, facings, everywhere) == grasp_stance(xy, counter.approach[2], everywhere)


def test_the_facings_start_from_the_approach_and_add_only_the_sides_the_object_is_near() -> None:
    counter = Box("counter", x=1.75, y=0.55, half_x=0.2, half_y=0.7, height=0.25)
    middle = stance_facings(0.0, counter, (1.65, 0.55))  # 0.1 m in from the west edge, far from both ends
    assert middle[0] == 0.0
    assert not any(abs(abs(f) - math.pi / 2) < 0.1 or abs(abs(f) - math.pi) < 0.1 for f in middle)
    south_end = stance_facings(0.0, counter, (1.65, -0.05))  # 0.1 m from the south end too
    assert south_end[0] == 0.0 and any(f == pytest.approx(math.pi / 2) for f in south_end)
    # turned a little before going round the surface, turned further last
    assert [abs(f) for f in south_end[1:3]] == pytest.approx([0.35, 0.35])
    assert south_end.index(pytest.approx(math.pi / 2)) < south_end.index(pytest.approx(0.7))
    assert stance_facings(0.3, None, (0.0, 0.0))[0] == 0.3


@pytest.mark.slow
def test_a_fetch_of_the_apple_behind_a_chair_picks_it_from_the_counters_end_touching_the_chair_with_nothing() -> None:
    """In physics, world seed 0: the chair stands where the feet go for the apple. The fetch walks round the
    counter's end (planned to a point behind the new stance: straight from the counter's staging point it walked
    through the chair and fell) and picks the apple up; it never says "no room", never touches the chair or the
    counter, and says "here it is" only with the apple in the hand. (On the way back the apple sometimes slips out,
    not traced: the fetch then says so, and that ending is accepted here.)"""
    from harness.behaviour_judge import run_judged
    from robot.interface import BehaviourState
    from robot.model.scene import object_body_name

    status, judge = run_judged("fetch", {"object": "green apple"}, 0)
    assert status is not None
    said = f"{status.state.value}: {status.reason}; {status.feedback}"  # all of it when it fails (pytest cuts it)
    assert any(line.startswith("carrying the green apple") for line in status.feedback), said
    assert not any("no room" in line for line in status.feedback), said
    assert [c["what"] for c in judge.collisions if "chair" in c["what"]] == []
    # the counter: at most a fingertip on its edge as the hand comes over it (seen once in a CI run), never the arm
    counter = [c["what"] for c in judge.collisions if "kitchen_counter" in c["what"]]
    assert [what for what in counter if "finger" not in what] == []
    data = judge.backend.data
    in_hand = math.dist(data.body(object_body_name("green apple")).xpos, data.site("right_hand").xpos) < 0.06
    if status.state == BehaviourState.SUCCEEDED:
        assert "here it is" in status.feedback[-1] and in_hand
    else:
        assert status.reason.startswith("the green apple is no longer in my hand"), status.reason
        assert not in_hand
