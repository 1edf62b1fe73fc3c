from __future__ import annotations

import pytest

from robot.interface import Plan, Step
from robot.planning.context import PlanningContext
from robot.planning.planner import PlanningError
from robot.planning.rules import RulesPlanner
from robot.planning.validator import validate_plan, validate_plan_json
from robot.planning.world_context import WorldContext


@pytest.fixture
def world(layout) -> WorldContext:
    return WorldContext.from_layout(layout)


def actions(plan: Plan) -> list[tuple[str, str]]:
    return [(s.action, next(iter(s.args.values()))) for s in plan.steps]


FETCH_MUG = [
    ("navigate_to", "kitchen counter"),
    ("detect_object", "red mug"),
    ("pick_object", "red mug"),
]


@pytest.mark.parametrize(
    "text",
    [
        "pick up the red mug from the kitchen counter",
        "Pick up the red mug from the kitchen counter.",
        "grab the red cup off the counter",
        "please get the mug",
        "take the red mug from the kitchen",
    ],
)
def test_paraphrases_of_the_capstone_give_the_same_fetch(world, text: str) -> None:
    plan = RulesPlanner().plan(text, PlanningContext(world))
    assert actions(plan)[:3] == FETCH_MUG
    assert plan.steps[-1].action == "say"
    assert validate_plan(plan, world)[1] == []


def test_bring_to_a_place_picks_then_places(world) -> None:
    plan = RulesPlanner().plan("bring the red mug to the living-room table", PlanningContext(world))
    assert actions(plan)[:5] == [
        *FETCH_MUG,
        ("navigate_to", "living-room table"),
        ("place_object", "living-room table"),
    ]
    assert validate_plan(plan, world)[1] == []


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("go to the dock", [("navigate_to", "charging dock")]),
        ("walk to the living room table", [("navigate_to", "living-room table")]),
        ("find the apple", [("detect_object", "green apple")]),
        ("where is the bottle", [("detect_object", "blue bottle")]),
        ("say hello there", [("say", "hello there")]),
    ],
)
def test_other_intents(world, text: str, expected: list[tuple[str, str]]) -> None:
    assert actions(RulesPlanner().plan(text, PlanningContext(world)))[: len(expected)] == expected


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("pick up the purple elephant", "unknown object 'purple elephant'"),
        ("go to the garage", "unknown place 'garage'"),
        ("do a backflip", "I don't understand"),
        ("   ", "empty command"),
    ],
)
def test_unknown_names_and_intents_are_errors_not_guesses(world, text: str, message: str) -> None:
    with pytest.raises(PlanningError, match=message):
        RulesPlanner().plan(text, PlanningContext(world))


def test_holding_the_object_skips_the_fetch(layout) -> None:
    world = WorldContext.from_layout(layout, held_object="red mug")
    plan = RulesPlanner().plan("bring the red mug to the table", PlanningContext(world))
    assert actions(plan)[0] == ("navigate_to", "living-room table")


def test_validator_rejects_unknown_action_with_a_clear_reason(world) -> None:
    plan, errors = validate_plan_json({"steps": [{"action": "fly_to", "args": {"target": "moon"}}]}, world)
    assert plan is None
    assert errors == [
        "step 1: unknown action 'fly_to' (known: navigate_to, detect_object, pick_object, "
        "place_object, say, look_around, describe_scene, go_home, wait, stop)"
    ]


@pytest.mark.parametrize(
    ("plan_json", "fragment"),
    [
        ({}, "'steps' is a required property"),
        ({"steps": []}, "should be non-empty"),
        ({"steps": [{"action": "say", "args": {}}]}, "takes exactly one string argument 'text'"),
        ({"steps": [{"action": "say", "args": {"text": 3}}]}, "takes exactly one string argument"),
        ({"steps": [{"action": "say", "args": {"text": "x"}}], "extra": 1}, "Additional properties"),
        ([1, 2], "steps/0"),
        ("not a plan", "is not of type 'object'"),
    ],
)
def test_validator_rejects_malformed_plans(world, plan_json, fragment: str) -> None:
    plan, errors = validate_plan_json(plan_json, world)
    assert plan is None
    assert any(fragment in e for e in errors), errors


def test_validator_checks_the_world_and_the_order(world) -> None:
    bad = Plan(
        (
            Step("navigate_to", {"target": "moon"}),
            Step("place_object", {"location": "kitchen counter"}),
            Step("pick_object", {"object": "red mug"}),
            Step("pick_object", {"object": "green apple"}),
        )
    )
    plan, errors = validate_plan(bad, world)
    assert plan is None
    assert errors == [
        "step 1: unknown place 'moon' (known: kitchen counter, living-room table, charging dock; or a pose "
        "'x, y' or 'x, y, heading deg' in metres)",
        "step 2: place_object before any pick_object: the robot holds nothing",
        "step 4: cannot pick 'green apple' while holding 'red mug'",
    ]


def test_validator_canonicalises_aliases(world) -> None:
    plan, errors = validate_plan(Plan((Step("navigate_to", {"target": "Counter"}),)), world)
    assert errors == []
    assert plan.steps[0].args == {"target": "kitchen counter"}
