"""Typed and spoken commands about behaviours, read before the planner: other wordings than the examples, world
names by alias, and ordinary commands left to the planner."""

from __future__ import annotations

import pytest

from robot.behaviours.intents import Intent, control_word, read_intent
from robot.model.world import generate_world
from robot.planning.world_context import WorldContext

BEHAVIOURS = ("demo", "fetch", "patrol", "tour", "wave_hello")


@pytest.fixture(scope="module")
def world() -> WorldContext:
    return WorldContext.from_layout(generate_world(5))


@pytest.mark.parametrize(
    ("text", "intent"),
    [
        ("start the patrol", Intent("start", "patrol")),
        ("Please begin patrolling.", Intent("start", "patrol")),
        ("patrol 4 laps", Intent("start", "patrol", {"laps": 4})),
        (
            "do two rounds of patrol past the dock and the table",
            Intent("start", "patrol", {"waypoints": ["charging dock", "living-room table"], "laps": 2}),
        ),
        ("keep watch until I say stop", Intent("start", "patrol", {"laps": 0})),
        ("give a tour of the kitchen", Intent("start", "tour", {"places": ["kitchen counter"]})),
        ("show me around", Intent("start", "tour")),
        ("take us on a guided tour of the coffee table", Intent("start", "tour", {"places": ["living-room table"]})),
        ("start the fetch behaviour for the apple", Intent("start", "fetch", {"object": "green apple"})),
        (
            "run fetch with the bottle to the counter",
            Intent("start", "fetch", {"object": "blue bottle", "to": "kitchen counter"}),
        ),
        ("show us what you can do", Intent("start", "demo")),
        ("start wave hello", Intent("start", "wave_hello")),
        ("stop the patrol", Intent("stop", "patrol")),
        ("pause the tour", Intent("pause", "tour")),
        ("resume the behaviour", Intent("resume", "")),
    ],
)
def test_behaviour_commands_are_read(world: WorldContext, text: str, intent: Intent) -> None:
    assert read_intent(text, BEHAVIOURS, world.places, world.objects) == intent


@pytest.mark.parametrize(
    "text",
    ["fetch the red mug", "bring me the apple", "go to the kitchen", "stop", "look around", "what do you see"],
)
def test_ordinary_commands_stay_with_the_planner(world: WorldContext, text: str) -> None:
    assert read_intent(text, BEHAVIOURS, world.places, world.objects) is None


def test_a_bare_control_word_is_for_the_running_behaviour() -> None:
    assert control_word("Stop!") == "stop" and control_word("pause please") == "pause"
    assert control_word("carry on") == "resume" and control_word("go to the dock") is None
