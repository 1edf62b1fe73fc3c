"""Paraphrased commands with the plans they must give, in the default world (seed 0): the yardstick of every
planner backend (`humanoid bench planner`, and the tests).

A plan is right when it has the expected actions with the expected arguments; what a `say` step says is free (an
LLM words it its own way) but it must say something.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Protocol

from robot.interface import Plan
from robot.model.world import WorldLayout
from robot.planning.context import PlanningContext, Turn
from robot.planning.schema import canonical_plan_json
from robot.planning.world_context import WorldContext

Seed = list[dict[str, str]]

COUNTER, TABLE, DOCK = "kitchen counter", "living-room table", "charging dock"
MUG, BOTTLE, APPLE = "red mug", "blue bottle", "green apple"


def _say() -> dict[str, str]:
    return {"action": "say", "text": "*"}


def fetch(obj: str, source: str = COUNTER) -> Seed:
    return [
        {"action": "navigate_to", "target": source},
        {"action": "detect_object", "object": obj},
        {"action": "pick_object", "object": obj},
        _say(),
    ]


def carry(obj: str, place: str, held: bool = False) -> Seed:
    steps = [] if held else fetch(obj)[:-1]
    return [*steps, {"action": "navigate_to", "target": place}, {"action": "place_object", "location": place}, _say()]


def go(place: str) -> Seed:
    return [{"action": "navigate_to", "target": place}, _say()]


def find(obj: str) -> Seed:
    return [{"action": "detect_object", "object": obj}]


LOOK_AND_TELL: Seed = [{"action": "look_around"}, {"action": "describe_scene"}]
HOME: Seed = [{"action": "go_home"}, _say()]
STOP: Seed = [{"action": "stop"}]


@dataclass(frozen=True)
class Case:
    text: str
    plan: Seed
    held: str | None = None
    # earlier turns of the conversation: (command, its plan) — what "it" may refer to
    history: tuple[tuple[str, Seed], ...] = field(default=())


CASES: tuple[Case, ...] = (
    # the capstone, and other fetches
    Case("pick up the red mug from the kitchen counter", fetch(MUG)),
    Case("grab the red cup off the counter", fetch(MUG)),
    Case("please get the mug", fetch(MUG)),
    Case("take the red mug from the kitchen", fetch(MUG)),
    Case("could you pick up the coffee mug", fetch(MUG)),
    Case("fetch the red mug", fetch(MUG)),
    Case("pick the mug up", fetch(MUG)),
    Case("grasp the red mug on the counter", fetch(MUG)),
    Case("lift the cup from the kitchen counter", fetch(MUG)),
    Case("Robot, pick up the mug please.", fetch(MUG)),
    Case("grab the blue bottle", fetch(BOTTLE)),
    Case("pick up the water bottle from the counter", fetch(BOTTLE)),
    Case("get the green apple", fetch(APPLE)),
    Case("take the apple off the kitchen counter", fetch(APPLE)),
    Case("collect the bottle", fetch(BOTTLE)),
    # fetch it to the operator
    Case("bring me the apple", fetch(APPLE)),
    Case("bring me the red mug from the kitchen counter", fetch(MUG)),
    Case("can you bring me the bottle", fetch(BOTTLE)),
    Case("hand me the mug", fetch(MUG)),
    Case("give me the apple", fetch(APPLE)),
    Case("I want the water bottle", fetch(BOTTLE)),
    Case("can I have the red cup?", fetch(MUG)),
    Case("fetch me the green apple", fetch(APPLE)),
    Case("bring the mug to me", fetch(MUG)),
    Case("bring the apple here", fetch(APPLE)),
    # carry it somewhere
    Case("bring the red mug to the living-room table", carry(MUG, TABLE)),
    Case("put the red mug on the table", carry(MUG, TABLE)),
    Case("take the mug to the living room table", carry(MUG, TABLE)),
    Case("carry the bottle to the coffee table", carry(BOTTLE, TABLE)),
    Case("move the apple to the charging dock", carry(APPLE, DOCK)),
    Case("deliver the red cup to the table", carry(MUG, TABLE)),
    Case("place the blue bottle on the living room table", carry(BOTTLE, TABLE)),
    Case("bring the apple from the counter to the table", carry(APPLE, TABLE)),
    Case("could you take the water bottle over to the table please", carry(BOTTLE, TABLE)),
    Case("set the mug down on the table", carry(MUG, TABLE)),
    Case("put the apple on the dock", carry(APPLE, DOCK)),
    # go somewhere
    Case("go to the dock", go(DOCK)),
    Case("walk to the living room table", go(TABLE)),
    Case("navigate to the kitchen counter", go(COUNTER)),
    Case("head over to the kitchen", go(COUNTER)),
    Case("go to the charging station", go(DOCK)),
    Case("please walk over to the table", go(TABLE)),
    Case("move to the charger", go(DOCK)),
    Case("drive to the counter", go(COUNTER)),
    Case("go to the mug", go(COUNTER)),
    Case("walk to 1.2, 0.5", go("1.20, 0.50")),
    Case("go to (0.5, -0.25, 90 deg)", go("0.50, -0.25, 90 deg")),
    # find something
    Case("find the apple", find(APPLE)),
    Case("where is the bottle?", find(BOTTLE)),
    Case("look for the red mug", find(MUG)),
    Case("can you find the blue bottle", find(BOTTLE)),
    Case("search for the green apple", find(APPLE)),
    Case("locate the cup", find(MUG)),
    Case("do you see the apple", find(APPLE)),
    # look and tell
    Case("what do you see", LOOK_AND_TELL),
    Case("What can you see?", LOOK_AND_TELL),
    Case("describe the scene", LOOK_AND_TELL),
    Case("tell me what you see", LOOK_AND_TELL),
    Case("what is around you", LOOK_AND_TELL),
    Case("look around", [{"action": "look_around"}]),
    # home, wait, stop
    Case("go home", HOME),
    Case("return to your starting position", HOME),
    Case("go back home", HOME),
    Case("wait 5 seconds", [{"action": "wait", "seconds": "5"}]),
    Case("wait for three seconds", [{"action": "wait", "seconds": "3"}]),
    Case("pause for 2 s", [{"action": "wait", "seconds": "2"}]),
    Case("stop", STOP),
    Case("halt!", STOP),
    Case("stop moving", STOP),
    Case("cancel", STOP),
    # say
    Case("say hello", [{"action": "say", "text": "hello"}]),
    Case("tell me I am done", [{"action": "say", "text": "I am done"}]),
    Case("announce: dinner is ready", [{"action": "say", "text": "dinner is ready"}]),
    # what the robot holds, and what the conversation was about
    Case("bring the red mug to the table", carry(MUG, TABLE, held=True), held=MUG),
    Case("put it on the counter", carry(MUG, COUNTER, held=True), held=MUG),
    Case("bring it to the table", carry(APPLE, TABLE), history=(("find the apple", find(APPLE)),)),
    Case("pick it up", fetch(APPLE), history=(("where is the apple", find(APPLE)),)),
)


def seq(*parts: Seed) -> Seed:
    """Steps done one after the other: only the last part keeps its closing confirmation, and a step the previous
    part ended with (already there) is not repeated."""
    steps: list[dict[str, str]] = []
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        part = part if last or not part or part[-1] != _say() else part[:-1]
        for step in part:
            if not steps or steps[-1] != step:
                steps.append(step)
    return steps


def plan_matches(expected: Seed, actual: list[dict[str, Any]]) -> bool:
    """Same actions with the same arguments; a `say` expected as "*" may say anything (but something)."""
    if len(expected) != len(actual):
        return False
    for want, got in zip(expected, actual, strict=True):
        if want["action"] != got.get("action"):
            return False
        for key, value in want.items():
            if key == "action":
                continue
            if value == "*":
                if not str(got.get(key, "")).strip():
                    return False
            elif said_aloud(str(got.get(key, ""))) != said_aloud(value):
                return False
        if set(got) - set(want):
            return False
    return True


def normalise_text(text: str) -> str:
    """As said aloud: case, closing punctuation and the space in "good night" / "goodnight" make no difference."""
    return "".join(text.lower().strip().rstrip(".!").replace("-", " ").split())


def said_aloud(text: str) -> str:
    """An argument as the robot would say or use it: `normalise_text`, and no punctuation inside either (the comma in
    "hello, everybody" is not said; the point in "2.5" is kept). Case texts keep their commas apart (`normalise_text`):
    to the planner a comma can end a clause."""
    return normalise_text(_UNSPOKEN_PUNCTUATION.sub("", text))


_UNSPOKEN_PUNCTUATION = re.compile(r"[,;:!?]|\.(?!\d)")


class Asked(Protocol):
    """A command asked in a context: what the robot holds, and the conversation so far."""

    @property
    def held(self) -> str | None: ...
    @property
    def history(self) -> tuple[tuple[str, Seed], ...]: ...


def context_for(case: Asked, layout: WorldLayout) -> PlanningContext:
    """The planning context a case is asked in: the layout's world, what is held, the conversation so far."""
    history = tuple(
        Turn(command, Plan.from_dict(canonical_plan_json(plan)), "succeeded") for command, plan in case.history
    )
    return PlanningContext(WorldContext.from_layout(layout, held_object=case.held), history)
