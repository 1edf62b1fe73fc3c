"""A JSGF grammar of the commands the rules planner understands, with the world's own object and place names:
what the recogniser listens for (a small grammar is what makes an offline engine accurate, and fast).

Every word must be in the recogniser's pronunciation dictionary; phrases with a word it lacks are left out, and
`build_grammar` says which.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from robot.planning.rules import NUMBER_WORDS
from robot.planning.world_context import normalize

PICK = ("pick up", "grab", "get", "take", "fetch", "grasp", "lift", "collect", "retrieve")
GIVE = ("bring me", "fetch me", "get me", "hand me", "give me", "pass me", "i want", "i need", "can i have")
CARRY = ("bring", "carry", "deliver", "move", "take", "put", "place", "set", "drop")
GO = ("go", "walk", "navigate", "head", "move", "drive", "come")
FIND = ("find", "look for", "search for", "locate", "where is", "do you see", "can you see")
STOP = (
    "stop",
    "halt",
    "freeze",
    "cancel",
    "abort",
    "stop moving",
    "stand still",
    "stop everything",
    "emergency stop",
    "stop it",
)
STOP_AFTER = ("now", "right now")
LOOK = (
    "what do you see",
    "what can you see",
    "what do you see around you",
    "what is around you",
    "describe the scene",
    "tell me what you see",
    "look around",
    "what have you seen",
)
HOME = (
    "go home",
    "go back home",
    "return home",
    "come back home",
    "return to your starting position",
    "go back to where you started",
    "go back to your start",
)
POLITE = ("please", "robot", "hey robot", "can you", "could you", "would you")


@dataclass(frozen=True)
class Grammar:
    text: str
    left_out: tuple[str, ...]  # phrases with words the dictionary lacks
    pattern: re.Pattern[str]  # the same language as a regular expression over "word word ... "

    def write(self, path: Path) -> Path:
        path.write_text(self.text)
        return path

    def accepts(self, text: str) -> bool:
        """Whether a whole sentence is in the grammar (a recogniser returns a partial path when it gets lost)."""
        return bool(self.pattern.fullmatch(" ".join(normalize(text).split()) + " "))


def build_grammar(
    objects: dict[str, tuple[str, ...]], places: dict[str, tuple[str, ...]], vocabulary: set[str] | None = None
) -> Grammar:
    """The grammar for a world's objects and places (canonical names and aliases)."""
    left_out: list[str] = []

    def phrases(items: Iterable[str]) -> list[str]:
        kept = []
        for item in dict.fromkeys(normalize(i) for i in items):
            if vocabulary is not None and any(word not in vocabulary for word in item.split()):
                left_out.append(item)
            elif item:
                kept.append(item)
        return kept

    def alternatives(items: Iterable[str]) -> str:
        return " | ".join(phrases(items))

    object_names = [n for name, aliases in objects.items() for n in (name, *aliases)]
    place_names = [n for name, aliases in places.items() for n in (name, *aliases)]
    numbers = alternatives(NUMBER_WORDS)
    rules = [
        "#JSGF V1.0;",
        "grammar robot_commands;",
        "public <command> = [<polite>] <task> [please];",
        f"<polite> = {alternatives(POLITE)};",
        "<task> = <fetch> | <give> | <carry> | <go> | <home> | <find> | <look> | <wait> | <stop>;",
        f"<object> = [the | a | my] ({alternatives(object_names)}) | it | that;",
        f"<place> = [the] ({alternatives(place_names)});",
        f"<fetch> = ({alternatives(PICK)}) <object> [(from | off | on) <place>] | pick <object> up;",
        f"<give> = ({alternatives(GIVE)}) <object> [from <place>] | (bring | fetch | get) <object> (here | to me);",
        f"<carry> = ({alternatives(CARRY)}) <object> [(from | off) <place>] [down | over | back] "
        "(to | onto | on | into | in | at) <place>;",
        f"<go> = ({alternatives(GO)}) [back | over] (to | towards) (<place> | <object>);",
        f"<home> = {alternatives(HOME)};",
        f"<find> = ({alternatives(FIND)}) <object>;",
        f"<look> = {alternatives(LOOK)};",
        f"<wait> = (wait | pause | stay) [for] ({numbers}) (seconds | second);",
        f"<stop> = [okay | ok] ({alternatives(STOP)}) [{alternatives(STOP_AFTER)}];",
    ]
    return Grammar("\n".join(rules) + "\n", tuple(dict.fromkeys(left_out)), _to_regex(rules[2:]))


_TOKEN = re.compile(r"<[a-z_]+>|[()\[\]|]|[a-z0-9']+")


def _to_regex(rules: list[str]) -> re.Pattern[str]:
    """JSGF rule lines (`<name> = body;`, `public` allowed) as one regex for the public rule."""
    bodies: dict[str, str] = {}
    public = ""
    for line in rules:
        head, body = line.rstrip(";").split("=", 1)
        name = head.replace("public", "").strip()
        bodies[name] = body.strip()
        if head.strip().startswith("public"):
            public = name

    def render(name: str) -> str:
        out = []
        for token in _TOKEN.findall(bodies[name]):
            if token.startswith("<"):
                out.append(f"(?:{render(token)})")
            elif token == "(" or token == "[":
                out.append("(?:")
            elif token == "]":
                out.append(")?")
            elif token in ")|":
                out.append(token)
            else:
                out.append(re.escape(token) + " ")
        return "".join(out)

    return re.compile(render(public))
