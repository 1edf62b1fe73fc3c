"""Typed and spoken commands that start or control a behaviour ("start the patrol", "give a tour of the kitchen",
"fetch the red mug", "patrol three laps", "stop the patrol", "pause the tour"): read before the planner, so the
operator starts a mission the way they ask for anything else. Names come from the installed behaviours and the
world (places with their aliases, objects with theirs), not from a fixed list."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

NUMBERS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9, "ten": 10}
# How people name the missions that no ordinary command is about, beyond their names; any other behaviour (fetch,
# a user's) is started by name with a starting word ("start the fetch", "run wave"), as "fetch the mug" is a plan.
VERBS = {
    "tour": ("tour", "guided tour", "show me around", "show us around", "tour guide"),
    "patrol": ("patrol", "patrolling", "keep watch", "guard the"),
    "demo": ("demo", "demonstration", "show what you can do", "show off", "show us what you can do"),
}
CONTROL = {
    "stop": ("stop", "end", "cancel", "abort", "finish", "quit"),
    "pause": ("pause", "hold"),
    "resume": ("resume", "continue", "carry on", "go on with", "unpause"),
}
EXPLICIT = re.compile(r"^(?:please\s+)?(?:start|begin|run|launch|do|play)\b|\b(?:behaviour|behavior|mission)\b")


@dataclass(frozen=True)
class Intent:
    """What the text asks of behaviours: `action` is "start", "stop", "pause" or "resume"."""

    action: str
    name: str = ""
    params: dict[str, Any] = field(default_factory=dict)


def _norm(text: str) -> str:
    return " ".join(re.sub(r"[^a-z0-9' -]", " ", text.lower()).split())


def _mentions(text: str, phrase: str) -> bool:
    return re.search(rf"\b{re.escape(phrase)}\b", text) is not None


def read_intent(
    text: str,
    behaviours: Sequence[str],
    places: Mapping[str, Sequence[str]],
    objects: Mapping[str, Sequence[str]],
) -> Intent | None:
    """The behaviour intent in `text`, or None (then it is an ordinary command for the planner)."""
    said = _norm(text)
    if not said:
        return None
    named = _behaviour_named(said, behaviours)
    for action, words in CONTROL.items():
        if any(said.startswith(w + " ") or said == w for w in words) and (named or _mentions(said, "behaviour")):
            return Intent(action, named or "")
    if named is None:
        return None
    params: dict[str, Any] = {}
    found_places = _found(said, places)
    found_objects = _found(said, objects)
    if named == "tour" and found_places:
        params["places"] = found_places
    elif named == "patrol":
        if found_places:
            params["waypoints"] = found_places
        laps = re.search(r"\b(\d+|" + "|".join(NUMBERS) + r")\s+(?:laps?|times|rounds?)\b", said)
        if laps:
            params["laps"] = int(laps.group(1)) if laps.group(1).isdigit() else NUMBERS[laps.group(1)]
        elif re.search(r"\b(?:until|till) (?:i say )?stop", said) or "forever" in said:
            params["laps"] = 0
    elif named == "fetch":
        if found_objects:
            params["object"] = found_objects[0]
        target = re.search(r"\b(?:to|on|onto)\s+(?:the\s+)?(.+)$", said)
        destination = _found(target.group(1), places) if target else []
        if destination:
            params["to"] = destination[0]
    elif named == "demo" and found_objects:
        params["point_at"] = found_objects[0]
    return Intent("start", named, params)


def _behaviour_named(said: str, behaviours: Sequence[str]) -> str | None:
    for name, words in VERBS.items():
        if name in behaviours and any(_mentions(said, w) for w in words):
            return name
    if EXPLICIT.search(said):
        for name in behaviours:
            if _mentions(said, name) or _mentions(said, name.replace("_", " ")):
                return name
    return None


def _found(said: str, names: Mapping[str, Sequence[str]]) -> list[str]:
    """The world names mentioned (by name or alias), in the order said."""
    hits: list[tuple[int, str]] = []
    for name, aliases in names.items():
        spots = [m.start() for a in (name, *aliases) for m in re.finditer(rf"\b{re.escape(_norm(a))}\b", said)]
        if spots:
            hits.append((min(spots), name))
    return [name for _, name in sorted(hits)]


def control_word(text: str) -> str | None:
    """A bare "stop", "pause", "resume" (and their synonyms): said while a behaviour runs, it is for the behaviour."""
    said = _norm(text).removesuffix(" please").removeprefix("please ")
    return next((action for action, words in CONTROL.items() if said in words), None)
