"""Navigation goals given as a pose: parsed from a command or a click, validated, in one canonical form."""

from __future__ import annotations

import pytest

from robot.model.world import generate_world
from robot.navigation.goal import PoseGoal, parse_pose_goal
from robot.planning.context import PlanningContext
from robot.planning.rules import RulesPlanner
from robot.planning.validator import validate_plan_json
from robot.planning.world_context import WorldContext


@pytest.mark.parametrize(
    ("text", "goal"),
    [
        ("1.2, 0.5", PoseGoal(1.2, 0.5)),
        ("(-1.65, -1.15)", PoseGoal(-1.65, -1.15)),
        ("1.2 0.5 90", PoseGoal(1.2, 0.5, 90.0)),
        ("x=1.2 y=-0.5 yaw=270 deg", PoseGoal(1.2, -0.5, -90.0)),
        ("1.2m, 0.5m facing 45 degrees", PoseGoal(1.2, 0.5, 45.0)),
    ],
)
def test_a_pose_is_read_in_the_ways_people_type_it(text: str, goal: PoseGoal) -> None:
    assert parse_pose_goal(text) == pytest.approx(goal)
    assert parse_pose_goal(goal.text()) == pytest.approx(goal)  # the canonical form reads back the same


@pytest.mark.parametrize(
    "text", ["the kitchen", "1, 2, 3, 4", "1.2", "900, 0", "", "nan, 1", "inf, 0", "1e400, 2", "0.5, 0.5, nan"]
)
def test_what_is_not_a_pose_is_not_taken_for_one(text: str) -> None:
    assert parse_pose_goal(text) is None


def test_go_to_a_pose_plans_a_walk_there_and_the_validator_keeps_it_canonical() -> None:
    world = WorldContext.from_layout(generate_world(0))
    plan = RulesPlanner().plan("walk to (0.5, -0.25, 90 deg)", PlanningContext(world))
    assert plan.steps[0].action == "navigate_to" and plan.steps[0].args["target"] == "0.50, -0.25, 90 deg"
    checked, errors = validate_plan_json({"steps": [{"action": "navigate_to", "args": {"target": "1.2 0.5"}}]}, world)
    assert errors == [] and checked.steps[0].args["target"] == "1.20, 0.50"
    _, errors = validate_plan_json({"steps": [{"action": "navigate_to", "args": {"target": "the moon"}}]}, world)
    assert "unknown place 'the moon'" in errors[0] and "pose" in errors[0]
