"""Shift+click on the floor of the 3D view sends the robot there."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from app.click_goal import ClickToGo, floor_point
from robot.interface import CommandReply, ExecutePlan


def test_a_view_ray_meets_the_floor_where_it_points_down_and_never_when_it_looks_up() -> None:
    assert floor_point((0.0, 0.0, 2.0), (0.5, 0.0, -0.5)) == pytest.approx((2.0, 0.0))
    assert floor_point((1.0, -1.0, 3.0), (0.0, 0.0, -1.0)) == pytest.approx((1.0, -1.0))
    assert floor_point((0.0, 0.0, 2.0), (1.0, 0.0, 0.0)) is None
    assert floor_point((0.0, 0.0, 2.0), (0.0, 0.0, 1.0)) is None


class RecordingPort:
    def __init__(self) -> None:
        self.commands: list[object] = []

    def submit(self, command: object) -> CommandReply:
        self.commands.append(command)
        return CommandReply(True, "accepted")


class FakeScene:
    def __init__(self) -> None:
        self.registered: list[tuple[str | None, object]] = []

    def on_click(self, modifier: str | None = None):
        def register(callback):
            self.registered.append((modifier, callback))
            return callback

        return register


def test_a_shift_click_on_the_floor_submits_a_walk_to_that_point() -> None:
    scene = FakeScene()
    port = RecordingPort()
    clicks = ClickToGo(SimpleNamespace(scene=scene), port)  # type: ignore[arg-type]
    assert scene.registered and scene.registered[0][0] == "shift"  # plain clicks still orbit the camera
    clicks.on_click(SimpleNamespace(ray_origin=(-3.0, -2.0, 3.0), ray_direction=(0.6, 0.4, -0.6)))
    (command,) = port.commands
    assert isinstance(command, ExecutePlan)
    assert command.plan_json == {"steps": [{"action": "navigate_to", "args": {"target": "0.00, 0.00"}}]}
    clicks.on_click(SimpleNamespace(ray_origin=(0.0, 0.0, 3.0), ray_direction=(1.0, 0.0, 0.0)))  # the sky
    assert len(port.commands) == 1
