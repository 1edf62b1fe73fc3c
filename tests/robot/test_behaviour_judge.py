"""The behaviour bench's judge counts what truly touched: a contact list read torn by a simulation step (any two
geoms paired) is not a collision, a box against the robot is."""

from __future__ import annotations

import numpy as np
import pytest

from harness import behaviour_judge
from harness.behaviour_judge import Judge
from robot.model.world import generate_world
from robot.sim.backend import MujocoSimBackend


class _Standing:
    """What the judge reads from a state: the robot standing at the start, holding nothing."""

    def __init__(self, backend: MujocoSimBackend) -> None:
        self.held_object = None
        self.sim_time_s = float(backend.data.time)
        self.base_position = tuple(float(v) for v in backend.data.qpos[:3])


def _geom(backend: MujocoSimBackend, name: str) -> int:
    return int(backend.model.geom(name).id)


def _robot_geom_of(backend: MujocoSimBackend, body: str) -> int:
    model = backend.model
    return next(g for g in range(model.ngeom) if model.body(int(model.geom_bodyid[g])).name == body)


def test_a_torn_read_pairing_far_apart_geoms_is_not_a_collision(monkeypatch: pytest.MonkeyPatch) -> None:
    backend = MujocoSimBackend(generate_world(0))
    backend.step(0.5)
    judge = Judge(backend)
    trunk, floor = _robot_geom_of(backend, "body_link"), _geom(backend, "floor")
    monkeypatch.setattr(behaviour_judge, "_contact_pairs", lambda data: np.array([[trunk, floor]]))
    judge.watch(_Standing(backend))  # the trunk is ~0.2 m above the floor: a pair no step could have made
    assert judge.collisions == []


def test_a_box_against_the_robot_is_a_collision() -> None:
    backend = MujocoSimBackend(generate_world(0))
    backend.step(0.5)
    x, y = (float(v) for v in backend.data.qpos[:2])
    backend.place_obstacle(x + 0.12, y)  # into the robot's shins
    backend.step(0.02)
    judge = Judge(backend)
    judge.watch(_Standing(backend))
    assert any("spare_obstacle_0" in c["what"] for c in judge.collisions), judge.collisions
