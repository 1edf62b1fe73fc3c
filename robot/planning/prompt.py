"""The messages an LLM planner sends: the vocabulary and rules (system), then the world, the conversation, any
failure to recover from, and the command (user). Shared by every LLM backend so they are judged on one prompt."""

from __future__ import annotations

import json

from robot.planning.context import PlanningContext, Turn
from robot.planning.examples import CANNOT, example_turns
from robot.planning.schema import ACTIONS

Message = dict[str, str]


def system_prompt() -> str:
    lines = [
        "You are the task planner of a humanoid robot. Turn the operator's command into a plan: a JSON object",
        '{"steps": [...]} whose steps are actions from this list, each with exactly the arguments shown:',
    ]
    for name, spec in ACTIONS.items():
        args = ", ".join(f'"{a}": "..."' for a in spec.args)
        lines.append(f'- {{"action": "{name}"{", " + args if args else ""}}}: {spec.doc}')
    lines += [
        "Rules:",
        "- Use only the place and object names listed in the world state (exactly as written there).",
        "- To pick an object, first navigate_to the place where it is, then detect_object, then pick_object.",
        "- The robot holds one object at a time: place_object only while holding one, after navigate_to that place.",
        "- If the robot already holds the object, do not pick it again.",
        "- End a task with a short say step telling the operator what was done.",
        "- If asked to replan after a failure, plan only what is still needed from the robot's current state.",
        f"- If the command names a thing or place not in the world, or asks for what no action does, reply with "
        f'one step {{"action": "{CANNOT}", "reason": "..."}} saying why. Never plan something else instead.',
        "- Reply with the JSON object only, no explanation.",
    ]
    return "\n".join(lines)


def world_text(context: PlanningContext) -> str:
    world = context.world
    lines = ["World state:"]
    lines.append("- places: " + "; ".join(_named(name, aliases) for name, aliases in world.places.items()))
    objects = []
    for name, aliases in world.objects.items():
        where = world.object_locations.get(name)
        seen = next((k for k in world.known_objects if k.name == name), None)
        text = _named(name, aliases)
        if world.held_object == name:
            text += ", in the robot's hand"
        elif where:
            text += f", on the {where}"
        if seen is not None:
            x, y, z = seen.position
            text += f" (seen at x {x:.2f}, y {y:.2f}, z {z:.2f} m)"
        objects.append(text)
    lines.append("- objects: " + "; ".join(objects))
    lines.append(f"- the robot holds: {world.held_object or 'nothing'}")
    return "\n".join(lines)


def _named(name: str, aliases: tuple[str, ...]) -> str:
    others = [a for a in aliases if a != name]
    return f"{name} (also: {', '.join(others)})" if others else name


def _turn_text(turn: Turn) -> str:
    plan = json.dumps(turn.plan.to_seed_list()) if turn.plan is not None else "no plan"
    return f"- {turn.command!r}: {plan} -> {turn.outcome}"


def messages(command: str, context: PlanningContext) -> list[Message]:
    """The chat messages for one planning request."""
    parts = [world_text(context)]
    if context.history:
        parts.append("Recent commands (oldest first):\n" + "\n".join(_turn_text(t) for t in context.history))
    if context.failure:
        done = "; ".join(context.done) if context.done else "nothing"
        parts.append(f"Replanning: the last plan for this command failed: {context.failure}. Already done: {done}.")
    parts.append(f"Command: {command}")
    # worked examples as earlier turns of the chat, chosen for this command and made in this world
    return [
        {"role": "system", "content": system_prompt()},
        *example_turns(command, context),
        {"role": "user", "content": "\n\n".join(parts)},
    ]


def repair_messages(previous: list[Message], answer: str, errors: list[str]) -> list[Message]:
    """Ask again, showing the model its answer and what was wrong with it."""
    problems = "\n".join(f"- {e}" for e in errors)
    return [
        *previous,
        {"role": "assistant", "content": answer},
        {"role": "user", "content": f"That plan is not valid:\n{problems}\nReply with a corrected plan, JSON only."},
    ]
