"""The action vocabulary and the JSON schema every plan must satisfy (whoever wrote it: rules, an LLM, a human)."""

from __future__ import annotations

from typing import Any

import jsonschema

# action -> its single required argument (the seed's vocabulary)
ACTION_ARGUMENTS: dict[str, str] = {
    "navigate_to": "target",
    "detect_object": "object",
    "pick_object": "object",
    "place_object": "location",
    "say": "text",
}

MAX_STEPS = 20
MAX_ARG_LENGTH = 200


def _step_schema(action: str, arg: str) -> dict[str, Any]:
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["action", "args"],
        "properties": {
            "action": {"const": action},
            "args": {
                "type": "object",
                "additionalProperties": False,
                "required": [arg],
                "properties": {arg: {"type": "string", "minLength": 1, "maxLength": MAX_ARG_LENGTH}},
            },
        },
    }


PLAN_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "Plan",
    "type": "object",
    "additionalProperties": False,
    "required": ["steps"],
    "properties": {
        "steps": {
            "type": "array",
            "minItems": 1,
            "maxItems": MAX_STEPS,
            "items": {"oneOf": [_step_schema(a, arg) for a, arg in ACTION_ARGUMENTS.items()]},
        }
    },
}

_VALIDATOR = jsonschema.Draft202012Validator(PLAN_SCHEMA)


def schema_errors(plan_json: Any) -> list[str]:
    """Human-readable schema violations of a plan given as JSON (empty when it conforms)."""
    errors: list[str] = []
    if isinstance(plan_json, dict) and isinstance(plan_json.get("steps"), list):
        # Name unknown actions plainly instead of reporting every oneOf branch.
        for i, step in enumerate(plan_json["steps"]):
            if isinstance(step, dict) and "action" in step and step["action"] not in ACTION_ARGUMENTS:
                known = ", ".join(ACTION_ARGUMENTS)
                errors.append(f"step {i + 1}: unknown action {step['action']!r} (known: {known})")
        if errors:
            return errors
    for error in sorted(_VALIDATOR.iter_errors(plan_json), key=lambda e: list(e.absolute_path)):
        where = "/".join(str(p) for p in error.absolute_path) or "plan"
        if error.validator == "oneOf" and isinstance(error.instance, dict):
            action = error.instance.get("action")
            arg = ACTION_ARGUMENTS.get(action, "?")
            errors.append(f"{where}: {action!r} takes exactly one string argument {arg!r}")
        else:
            errors.append(f"{where}: {error.message}")
    return errors
