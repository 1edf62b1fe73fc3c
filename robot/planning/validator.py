"""Checks a plan against the schema, the action vocabulary and the world before anything moves."""

from __future__ import annotations

import math
from typing import Any

from robot.interface import Plan, Step
from robot.navigation.goal import parse_pose_goal
from robot.planning.schema import MAX_WAIT_S, canonical_plan_json, schema_errors
from robot.planning.world_context import WorldContext


def validate_plan_json(plan_json: Any, world: WorldContext) -> tuple[Plan | None, list[str]]:
    """Returns (plan with canonical names, []) when valid, else (None, errors). Takes our shape or the seed's."""
    plan_json = canonical_plan_json(plan_json)
    errors = schema_errors(plan_json)
    if errors:
        return None, errors
    return validate_plan(Plan.from_dict(plan_json), world)


def validate_plan(plan: Plan, world: WorldContext) -> tuple[Plan | None, list[str]]:
    """Semantic checks: known places and objects, sensible numbers, and an order that can work (pick before
    place, one object in hand at a time)."""
    errors: list[str] = []
    held = world.held_object
    canonical_steps = []
    for i, step in enumerate(plan.steps, start=1):
        args = dict(step.args)
        if step.action == "navigate_to":
            target = args["target"]
            resolved = world.resolve_place(target)
            thing = world.resolve_object(target) if resolved is None else None
            if thing is not None:  # "go to the mug": where the mug is believed to be
                resolved = world.object_locations.get(thing)
                if resolved is None:
                    errors.append(f"step {i}: where the {thing} is is not known: look for it first")
                    canonical_steps.append(step)
                    continue
            pose = parse_pose_goal(target) if resolved is None else None
            if pose is not None:
                args["target"] = pose.text()
            elif resolved is None:
                errors.append(
                    f"step {i}: unknown place {target!r} (known: {', '.join(world.places)}; or a pose "
                    f"'x, y' or 'x, y, heading deg' in metres)"
                )
            else:
                args["target"] = resolved
        elif step.action in ("detect_object", "pick_object"):
            resolved = world.resolve_object(args["object"])
            if resolved is None:
                errors.append(f"step {i}: unknown object {args['object']!r} (known: {', '.join(world.objects)})")
            else:
                args["object"] = resolved
                if step.action == "pick_object":
                    if held is not None:
                        errors.append(f"step {i}: cannot pick {resolved!r} while holding {held!r}")
                    held = resolved
        elif step.action == "place_object":
            resolved = world.resolve_place(args["location"])
            if resolved is None:
                errors.append(f"step {i}: unknown place {args['location']!r} (known: {', '.join(world.places)})")
            else:
                args["location"] = resolved
            if held is None:
                errors.append(f"step {i}: place_object before any pick_object: the robot holds nothing")
            held = None
        elif step.action == "wait":
            seconds = _seconds(args["seconds"])
            if seconds is None or not 0.0 < seconds <= MAX_WAIT_S:
                errors.append(
                    f"step {i}: wait needs a number of seconds above 0 and at most {MAX_WAIT_S:g}, "
                    f"not {args['seconds']!r}"
                )
            else:
                args["seconds"] = f"{seconds:g}"
        canonical_steps.append(Step(step.action, args))
    if errors:
        return None, errors
    return Plan(tuple(canonical_steps)), []


def _seconds(text: str) -> float | None:
    try:
        value = float(text.strip().removesuffix("s").strip())
    except ValueError:
        return None
    return value if math.isfinite(value) else None
