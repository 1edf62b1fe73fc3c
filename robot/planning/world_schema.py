"""The JSON schema an LLM's plan is held to, built from the robot's world: each action with exactly its arguments,
the world's place and object names as the only values they take, a pose as a pattern, and a `cannot` step.

A server or llama.cpp turns the schema into a grammar, so a small model cannot name a place that is not there or
leave out an argument. Without a way to say no it would have to plan something for "bring me the banana": the
`cannot` step (with its reason) is that way, and the planner turns it into a refusal.
"""

from __future__ import annotations

from typing import Any

from robot.planning.examples import CANNOT
from robot.planning.schema import ACTIONS, MAX_STEPS, MAX_WAIT_S
from robot.planning.world_context import WorldContext

# a pose on the map, as `PoseGoal.text()` writes it: "1.20, 0.50" or "1.20, 0.50, 90 deg" (no escapes: llama.cpp's
# grammar converter does not take them)
POSE_PATTERN = r"^-?[0-9]{1,2}([.][0-9]{1,2})?, -?[0-9]{1,2}([.][0-9]{1,2})?(, -?[0-9]{1,3} deg)?$"


def world_plan_schema(world: WorldContext, max_steps: int = MAX_STEPS) -> dict[str, Any]:
    """`{"steps": [...]}` in the seed's flat shape, one of the actions (or `cannot`) per step."""
    places, objects = list(world.places), list(world.objects)
    text = {"type": "string", "minLength": 1}  # (a length limit becomes a grammar of 200 nested rules: the
    # validator checks it)
    values: dict[str, dict[str, Any]] = {
        "target": {"anyOf": [_one_of(places + objects), {"type": "string", "pattern": POSE_PATTERN}]},
        "object": _one_of(objects),
        "location": _one_of(places),
        "text": text,
        "seconds": {"type": "integer", "minimum": 1, "maximum": int(MAX_WAIT_S)},
    }
    steps = [_step(name, {arg: values[arg] for arg in spec.args}) for name, spec in ACTIONS.items()]
    steps.append(_step(CANNOT, {"reason": text}))
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["steps"],
        "properties": {"steps": {"type": "array", "minItems": 1, "maxItems": max_steps, "items": {"anyOf": steps}}},
    }


def _one_of(names: list[str]) -> dict[str, Any]:
    return {"type": "string", "enum": names} if names else {"type": "string", "maxLength": 0}


def _step(action: str, args: dict[str, dict[str, Any]]) -> dict[str, Any]:
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["action", *args],
        "properties": {"action": {"const": action}, **args},
    }
