"""Shift+click on the floor of a 3D view sends the robot there, when an operator in control clicks; anyone else's
click is refused and said."""

from __future__ import annotations

import time

import pytest

from app.auth.roles import Principal, Role
from app.auth.scene_tokens import SceneGrant
from app.viz.click_goal import click_plan, floor_point
from app.viz.scene_clicks import SceneClicks
from robot.interface import Refusal
from tests.app.test_api import wait_until


def grant(name: str, role: Role) -> SceneGrant:
    return SceneGrant(name, role, f"login-{name}", time.time() + 60)


def test_a_view_ray_meets_the_floor_where_it_points_down_and_never_when_it_looks_up() -> None:
    assert floor_point((0.0, 0.0, 2.0), (0.5, 0.0, -0.5)) == pytest.approx((2.0, 0.0))
    assert floor_point((1.0, -1.0, 3.0), (0.0, 0.0, -1.0)) == pytest.approx((1.0, -1.0))
    assert floor_point((0.0, 0.0, 2.0), (1.0, 0.0, 0.0)) is None
    assert floor_point((0.0, 0.0, 2.0), (0.0, 0.0, 1.0)) is None


def test_a_click_on_the_floor_is_a_walk_to_that_point() -> None:
    plan, text = click_plan((-3.0, -2.0, 3.0), (0.6, 0.4, -0.6))
    assert plan == {"steps": [{"action": "navigate_to", "args": {"target": "0.00, 0.00"}}]}
    assert text == "go to 0.00, 0.00 (clicked in the 3D view)"
    assert click_plan((0.0, 0.0, 3.0), (1.0, 0.0, 0.0)) is None  # the sky


def test_clicks_are_commands_of_whoever_made_them(client) -> None:
    rt = client.runtime
    clicks = SceneClicks()
    clicks.runtime = rt
    floor = ((-2.4, -2.4, 3.0), (0.6, 0.4, -0.6))
    refused = clicks.handle(grant("vic", Role.VIEWER), *floor)
    assert not refused.accepted and refused.refusal == Refusal.FORBIDDEN and "viewers" in refused.message
    said = wait_until(lambda: next((e for e in rt.worker.recent_events() if e.kind == "mirror/click_refused"), None))
    assert "vic" in said.message and rt.worker.state().plan is None
    rt.control.take(Principal("bea", Role.OPERATOR), take_over=False)
    held = clicks.handle(grant("ada", Role.OPERATOR), *floor)
    assert not held.accepted and "bea has control" in held.message
    rt.control.release(Principal("bea", Role.OPERATOR))
    accepted = clicks.handle(grant("ada", Role.OPERATOR), *floor)
    assert accepted.accepted and rt.control.holder.name == "ada"
    plan = wait_until(lambda: rt.worker.state().plan)
    assert [(s.action, s.args) for s in plan.steps] == [("navigate_to", {"target": "0.60, -0.40"})]
    commands = client.get(f"/api/sessions/{rt.recorder.session_id}").json()["commands"]
    assert [(c["source"], c["accepted"]) for c in commands] == [("3d_view", False)] * 2 + [("3d_view", True)]
