"""The action vocabulary and the JSON schema every plan must satisfy (whoever wrote it: rules, an LLM, a human).

Plans are read in two shapes: ours, `{"steps": [{"action": "pick_object", "args": {"object": "red mug"}}]}`, and
the seed's, a list of flat actions `[{"action": "pick_object", "object": "red mug"}]` (what LLM prompts ask for,
optionally wrapped as `{"steps": [...]}`). `canonical_plan_json` turns either into ours before checking.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import jsonschema


@dataclass(frozen=True)
class ActionSpec:
    """An action the robot can do: its arguments (all required) and what it does, for people and prompts."""

    args: tuple[str, ...]
    doc: str


ACTIONS: dict[str, ActionSpec] = {
    "navigate_to": ActionSpec(("target",), "walk to a known place, or to a pose 'x, y' / 'x, y, heading deg' (m)"),
    "detect_object": ActionSpec(("object",), "look for a known object and remember where it is"),
    "pick_object": ActionSpec(("object",), "grasp a known object within reach and lift it (hands must be free)"),
    "place_object": ActionSpec(("location",), "put the held object down on a known place the robot stands at"),
    "say": ActionSpec(("text",), "speak a sentence to the operator"),
    "look_around": ActionSpec((), "turn the head (and the body) once round and remember every object seen"),
    "describe_scene": ActionSpec((), "say which objects the robot has seen and where"),
    "go_home": ActionSpec((), "walk back to where the robot started"),
    "wait": ActionSpec(("seconds",), "stand still for a number of seconds (0-60)"),
    "stop": ActionSpec((), "stop what the robot is doing and stand still"),
}

# The seed's five actions with their single argument, kept for code that predates the extra actions.
ACTION_ARGUMENTS: dict[str, str] = {name: spec.args[0] for name, spec in ACTIONS.items() if len(spec.args) == 1}

MAX_STEPS = 20
MAX_ARG_LENGTH = 200
MAX_WAIT_S = 60.0


def _arg_schema(arg: str) -> dict[str, Any]:
    if arg == "seconds":  # a number, or its text ("3"): both reach the robot as text
        return {"anyOf": [{"type": "number"}, {"type": "string", "minLength": 1, "maxLength": 20}]}
    return {"type": "string", "minLength": 1, "maxLength": MAX_ARG_LENGTH}


def _step_schema(action: str, spec: ActionSpec) -> dict[str, Any]:
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["action", "args"],
        "properties": {
            "action": {"const": action},
            "args": {
                "type": "object",
                "additionalProperties": False,
                "required": list(spec.args),
                "properties": {arg: _arg_schema(arg) for arg in spec.args},
            },
        },
    }


def _steps_object(step: dict[str, Any], max_steps: int) -> dict[str, Any]:
    """`{"steps": [step, ...]}` with 1 to `max_steps` steps."""
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["steps"],
        "properties": {"steps": {"type": "array", "minItems": 1, "maxItems": max_steps, "items": step}},
    }


PLAN_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "Plan",
    **_steps_object({"oneOf": [_step_schema(a, spec) for a, spec in ACTIONS.items()]}, MAX_STEPS),
}


def flat_plan_schema(max_steps: int = MAX_STEPS) -> dict[str, Any]:
    """The schema of `{"steps": [flat actions]}`, the shape asked of LLMs (structured output / grammars).

    Kept simple (no oneOf) so grammar converters and small models cope: each step has an action from the
    vocabulary and optional string arguments; the validator then checks which arguments each action needs.
    """
    arg_names = sorted({arg for spec in ACTIONS.values() for arg in spec.args})
    step = {
        "type": "object",
        "additionalProperties": False,
        "required": ["action"],
        "properties": {
            "action": {"type": "string", "enum": list(ACTIONS)},
            **{a: {"type": "string"} for a in arg_names},
        },
    }
    return _steps_object(step, max_steps)


_VALIDATOR = jsonschema.Draft202012Validator(PLAN_SCHEMA)


def canonical_plan_json(plan_json: Any) -> Any:
    """The seed's flat shape (a list, or `{"steps": [...]}` of flat actions) as ours; anything else unchanged,
    for the schema check to report."""
    if isinstance(plan_json, list):
        plan_json = {"steps": plan_json}
    if not isinstance(plan_json, dict) or not isinstance(plan_json.get("steps"), list):
        return plan_json
    steps = []
    for step in plan_json["steps"]:
        if isinstance(step, dict) and "action" in step and "args" not in step:
            step = {"action": step["action"], "args": {k: v for k, v in step.items() if k != "action"}}
        steps.append(step)
    return {**plan_json, "steps": steps}


def schema_errors(plan_json: Any) -> list[str]:
    """Human-readable schema violations of a plan given as JSON (empty when it conforms)."""
    errors: list[str] = []
    if isinstance(plan_json, dict) and isinstance(plan_json.get("steps"), list):
        # Name unknown actions and wrong arguments plainly instead of reporting every oneOf branch.
        for i, step in enumerate(plan_json["steps"]):
            if isinstance(step, dict) and "action" in step and step["action"] not in ACTIONS:
                known = ", ".join(ACTIONS)
                errors.append(f"step {i + 1}: unknown action {step['action']!r} (known: {known})")
        if errors:
            return errors
    for error in sorted(_VALIDATOR.iter_errors(plan_json), key=lambda e: list(e.absolute_path)):
        where = "/".join(str(p) for p in error.absolute_path) or "plan"
        if error.validator == "oneOf" and isinstance(error.instance, dict):
            errors.append(f"{where}: {_arguments_phrase(error.instance.get('action'))}")
        else:
            errors.append(f"{where}: {error.message}")
    return errors


def _arguments_phrase(action: Any) -> str:
    spec = ACTIONS.get(action) if isinstance(action, str) else None
    if spec is None:
        return f"{action!r} is not an action"
    if not spec.args:
        return f"{action!r} takes no arguments"
    if spec.args == ("seconds",):
        return f"{action!r} takes exactly one argument 'seconds' (a number)"
    return f"{action!r} takes exactly one string argument {spec.args[0]!r}"
