"""Worked examples for an LLM planner, shown as earlier turns of the chat: made for the robot's own world by the
rules planner (so every example names real places and objects and is a valid plan), and chosen per command (the
ones worded most like it), with one example of saying "cannot".

Small models copy what they see: fixed examples in the system prompt were copied whatever the command; examples
close to the command, as chat turns, are copied usefully.
"""

from __future__ import annotations

import json
from dataclasses import replace

from rapidfuzz import fuzz

from robot.planning.context import PlanningContext
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext

Message = dict[str, str]
CANNOT = "cannot"

# {object} and {other} are two of the world's objects, {place} and {there} two of its places
_COMMANDS = (
    "pick up the {object}",
    "bring me the {object}",
    "could you bring the {object} to the {there}",
    "put the {object} on the {place}",
    "pick up the {object} and put it on the {there}",
    "go to the {place}",
    "take a walk to the {there}",
    "find the {other}",
    "where is the {object}",
    "what do you see",
    "look around",
    "go home",
    "wait 5 seconds",
    "stop",
    "say hello",
    "tell everyone that dinner is ready",
    "first go to the {place}, then find the {other}",
    "go to the {there} after you say hello",
)
# what no plan can do: the answer is a `cannot` step with the reason
_CANNOT = (
    ("bring me the banana", "there is no banana here"),
    ("go to the garage", "there is no garage here"),
    ("do a backflip", "I cannot do backflips"),
    ("make me a cup of coffee", "I cannot make coffee"),
)


def example_turns(command: str, context: PlanningContext, count: int = 3) -> list[Message]:
    """User/assistant turns: the `count` examples most like `command` (the closest last, next to it), after the
    closest example of a refusal. Alike means the same kind of plan where the rules planner reads the command,
    else worded alike."""
    examples = _examples(context.world)
    if not examples:
        return []
    actions = _actions_for(command, context)

    def likeness(example: tuple[str, str]) -> float:
        words = fuzz.token_set_ratio(command, example[0])
        if actions is None:
            return words
        return fuzz.ratio(actions, [s["action"] for s in json.loads(example[1])["steps"]]) + words / 10

    planned = sorted((e for e in examples if not _refusal(e)), key=likeness)
    refusals = sorted((e for e in examples if _refusal(e)), key=lambda e: fuzz.token_set_ratio(command, e[0]))
    turns: list[Message] = []
    for text, answer in [*refusals[-1:], *planned[-count:]]:
        turns += [{"role": "user", "content": f"Command: {text}"}, {"role": "assistant", "content": answer}]
    return turns


def _actions_for(command: str, context: PlanningContext) -> list[str] | None:
    """The actions the rules planner would plan for the command, if it reads it."""
    from robot.planning.rules import RulesPlanner

    try:
        return [s.action for s in RulesPlanner().plan(command, context).steps]
    except PlanningError:
        return None


def _refusal(example: tuple[str, str]) -> bool:
    return f'"{CANNOT}"' in example[1]


_MADE: dict[tuple[object, ...], tuple[tuple[str, str], ...]] = {}  # per world: planning them takes ~10 ms


def _examples(world: WorldContext) -> tuple[tuple[str, str], ...]:
    key = (tuple(world.places.items()), tuple(world.objects.items()), tuple(sorted(world.object_locations.items())))
    if key not in _MADE:
        if len(_MADE) >= 8:
            _MADE.clear()
        _MADE[key] = _made_for(world)
    return _MADE[key]


def _made_for(world: WorldContext) -> tuple[tuple[str, str], ...]:
    """Every example command with its plan, in this world (the world as laid out: nothing held, no history)."""
    from robot.planning.rules import RulesPlanner

    objects, places = list(world.objects), list(world.places)
    if not objects or not places:
        return ()
    names = {"object": objects[0], "other": objects[-1], "place": places[0], "there": places[-1]}
    context = PlanningContext(replace(world, held_object=None))
    planner = RulesPlanner()
    examples = []
    for template in _COMMANDS:
        text = template.format(**names)
        try:
            plan = planner.plan(text, context)
        except PlanningError:
            continue
        examples.append((text, json.dumps({"steps": plan.to_seed_list()})))
    for text, reason in _CANNOT:
        examples.append((text, json.dumps({"steps": [{"action": CANNOT, "reason": reason}]})))
    return tuple(examples)
