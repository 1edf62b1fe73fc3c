"""Deterministic, offline planner for commands in everyday wording.

A command is cut into its steps in the order they are to be done (`language.clauses`: "first ... then",
"... after you ..."), each step is read for what it asks (`language.intents`: fetch, bring to, go to, go home,
find, look around, what do you see, wait, stop, say; politeness and fillers cut away) and its names are looked up
in the world (`language.names`: aliases, everyday words, colours and rooms, near misses). A name that is not in
the world, or a request that is no ability, is refused with what the robot can do instead; two close readings
make it ask one question (`ClarificationNeeded`), never guess.

"it" is the object this command last named, else the one in hand, else the last one the conversation named.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace

from robot.interface import Plan, Step
from robot.navigation.goal import parse_pose_goal
from robot.planning.context import PlanningContext
from robot.planning.language.clauses import split_command
from robot.planning.language.intents import Step as Request
from robot.planning.language.intents import elliptic_step, read_step
from robot.planning.language.lexicon import NUMBER_WORDS, OBJECT_PRONOUNS, PLACE_PRONOUNS
from robot.planning.language.names import QUESTION_START, WorldNames
from robot.planning.language.tokens import tokenize
from robot.planning.planner import ClarificationNeeded, PlanningError

__all__ = ["NUMBER_WORDS", "RulesPlanner"]


class RulesPlanner:
    name = "rules"

    def __init__(self) -> None:
        _read("go home, then say hello")  # builds the verb tables and patterns now (~0.3 s), not on a command

    def describe(self) -> str:
        return "built-in rules (offline)"

    def plan(self, text: str, context: PlanningContext) -> Plan:
        raw = _LEADING_OR.sub("", text.strip())
        if not raw:
            raise PlanningError("empty command")
        answer = self._answer(raw, context)
        if answer is not None:
            return answer
        try:
            return self._plan(raw, context)
        except ClarificationNeeded:
            raise
        except PlanningError:
            recovered = self._after_garbled_frame(raw, context)
            if recovered is None:
                raise
            return recovered

    def _after_garbled_frame(self, raw: str, context: PlanningContext) -> Plan | None:
        """ "Cut your please bring the red mug", "What do you mind picking up the bottle": a recogniser often garbles
        the polite frame a request starts with. Read from the first word on which the rest is a request, if the
        words skipped are few, end in a word of such a frame, and say nothing the plan would leave out: no
        negation, no second step, no name in the world."""
        words = [t for t in tokenize(raw) if not t.is_break]
        world_words = WorldNames(context.world).words()
        for start in range(1, min(MAX_GARBLED_FRAME_WORDS, len(words) - 1) + 1):
            skipped = {w.text for w in words[: start + 1]}  # and the first word read: "..., then bring"
            if skipped & (_NOT_A_FRAME | world_words):
                return None
            if words[start - 1].text not in _FRAME_WORDS:
                continue  # a frame ends the words before the request: "could you" "please" "do you mind"
            rest = raw[words[start].start :]
            requests = _read(rest)
            if not requests or requests[0].action in ("topic", "chatter", "nothing"):
                continue
            try:
                return self._plan(rest, context)
            except PlanningError:
                continue
        return None

    def _plan(self, raw: str, context: PlanningContext, chosen: frozenset[str] = frozenset()) -> Plan:
        requests = _read(raw)
        if not requests:
            raise PlanningError(f"I don't understand {raw!r}. {self.abilities(context)}")
        if all(r.action == "stop" for r in requests):
            return Plan((Step("stop", {}),))
        return _Composer(context, raw, self.abilities(context), chosen).compose(requests)

    def _answer(self, raw: str, context: PlanningContext) -> Plan | None:
        """ "the red mug", said after "Did you mean the red mug or the blue bottle?": the command that was asked
        about, with that reading."""
        asked = context.history[-1] if context.history else None
        if asked is None or not asked.outcome.startswith(f"refused: {QUESTION_START}"):
            return None
        requests = [r for r in _read(raw) if r.action not in ("nothing", "chatter")]
        if len(requests) != 1 or requests[0].action != "topic":
            return None
        chosen = WorldNames(context.world).name_of(requests[0].thing or "")
        if chosen is None:
            return None
        try:
            return self._plan(asked.command, replace(context, history=context.history[:-1]), frozenset({chosen}))
        except PlanningError:
            return None

    @staticmethod
    def abilities(context: PlanningContext) -> str:
        """What the robot can do, said when it cannot do what it was asked."""
        world = context.world
        return (
            f"I can fetch or carry {_any_of(f'the {o}' for o in world.objects)}; go to "
            f"{_any_of([*(f'the {p}' for p in world.places), 'home'])}; find things; look around and tell what I "
            "see; say something; wait; stop."
        )


def _read(raw: str) -> list[Request]:
    """The command's requests in order; a piece that is no request is refused, unless it continues a message
    ("say hello, world") or names a thing for a pronoun after it ("the red mug, bring it to the table")."""
    requests: list[Request] = []
    for whole in split_command(raw):
        previous = requests[-1] if requests else None
        if previous is not None and previous.open_message:  # "announce: dinner is ready"
            start = whole.words[0].start
            requests[-1] = Request("say", text=raw[start : whole.words[-1].end], text_start=start)
            continue
        clause = whole.without_prefixes()
        if not clause.without_suffixes().words:
            continue  # "thanks", "robot": nothing asked
        request = read_step(clause)
        if request is None and previous is not None:
            request = elliptic_step(clause.without_suffixes(), previous)
        if request is None and previous is not None and previous.action == "say":  # "say hello, world"
            start = previous.text_start
            requests[-1] = Request("say", text=raw[start : whole.words[-1].end], text_start=start)
            continue
        if request is None:
            text = clause.without_suffixes().text
            request = Request("chatter" if _STATEMENT.match(text) else "topic", thing=text)
        requests.append(request)
    return requests


# "Or bring me the bottle": a recogniser hears the "uh" or "er" a command starts with as "or" (only there: "go to
# the dock or the table" is no sequence)
_LEADING_OR = re.compile(r"^or\b[\s,.]*", re.IGNORECASE)

# a garbled polite frame before a request ("cut your please" for "could you please") is at most this long and
# ends in one of its words; a word that changes or adds to the request means it is not a frame
MAX_GARBLED_FRAME_WORDS = 4
_FRAME_WORDS = frozenset(("you", "your", "please", "mind", "could", "would", "can", "will", "kindly"))
_NOT_A_FRAME = frozenset(
    ("not", "no", "never", "nor", "without", "instead", "and", "then", "after", "before", "but", "or", "stop")
)

# "I'm thirsty, ...", "it's late, ...": said about things, not asked of the robot
_STATEMENT = re.compile(
    r"(?:i|we|it|this|that|there|he|she|they) (?:am|are|is|was|were|think|feel|guess|have|had|got|will|would|"
    r"just|really|do not|did not|cannot|can not)\b"
)


@dataclass
class _Said:
    """The steps one request became, and what the robot says when it is the last."""

    steps: list[Step]
    confirmation: str | None = None


class _Composer:
    """Turns requests into one plan, keeping track of what the robot will hold and what was last named."""

    def __init__(self, context: PlanningContext, raw: str, abilities: str, chosen: frozenset[str]) -> None:
        self.world = context.world
        self.names = WorldNames(context.world, chosen)
        self.raw = raw
        self.abilities = abilities
        self.held = context.world.held_object
        self.last_object: str | None = None  # named in this command
        self.earlier_object = _last_object(context)  # named earlier in the conversation
        self.last_place: str | None = None

    def compose(self, requests: list[Request]) -> Plan:
        requests = self._named_after([r for r in requests if r.action not in ("nothing", "chatter")])
        if len(requests) == 1 and requests[0].action == "topic" and self._names_an_object(requests[0].thing):
            requests = [Request("fetch", thing=requests[0].thing, to_me=True)]  # "the red mug, please"
        parts: list[_Said] = []
        for i, request in enumerate(requests):
            if request.action == "stop" and i > 0:
                continue  # "go to the dock and stop there": the stop is where the step ends
            if request.action == "topic":
                if i == len(requests) - 1:
                    raise PlanningError(f"I don't understand {self.raw!r}. {self.abilities}")
                self._topic(request.thing or "")
                continue
            parts.append(self._steps(request))
        steps: list[Step] = []
        for i, part in enumerate(parts):
            said = part.steps
            if i == len(parts) - 1 and part.confirmation:
                said = [*said, Step("say", {"text": part.confirmation})]
            for step in said:
                if not steps or steps[-1] != step:  # already there: walking there again is no step
                    steps.append(step)
        if not steps:
            raise PlanningError(f"I don't understand {self.raw!r}. {self.abilities}")
        return Plan(tuple(steps))

    def _named_after(self, requests: list[Request]) -> list[Request]:
        """ "bring me something to drink, the bottle", "get it, the red mug": an object named on its own right after
        a request whose thing names no one object is that thing; so is one a fetch names right after a vague one."""
        named: list[Request] = []
        for request in requests:
            previous = named[-1] if named else None
            if (
                request.action == "topic"
                and previous is not None
                and previous.action in ("fetch", "carry", "find")
                and self._one_object(previous.thing) is None
            ):
                if self._one_object(request.thing) is None:
                    self._topic(request.thing or "")  # the lemonade: refused as not in the world, not asked about
                else:
                    named[-1] = replace(previous, thing=request.thing)
                    continue
            if (
                request.action == "fetch"
                and previous is not None
                and previous.action == "fetch"
                and _VAGUE_HEAD.fullmatch((previous.thing or "").strip())
                and self._one_object(request.thing) is not None
            ):  # "I'd love a drink, grab the water bottle": the fetch that names it says which drink
                named[-1] = replace(request, to_me=previous.to_me or request.to_me)
                continue
            named.append(request)
        return named

    def _one_object(self, phrase: str | None) -> str | None:
        """The one object in the world the phrase names, if any (no pronoun, nothing vague or ambiguous)."""
        if not phrase or phrase.strip() in OBJECT_PRONOUNS:
            return None
        try:
            return self.names.object(phrase).name
        except PlanningError:  # (a question to ask is one too)
            return None

    def _steps(self, request: Request) -> _Said:
        action = request.action
        if action == "fetch":
            obj, source = self._object(request)
            then = f"Here is the {obj}." if request.to_me else f"I have picked up the {obj}."
            return _Said(self._fetch(obj, source), then)
        if action == "carry":
            obj, source = self._object(request)
            place = self._place(request.place or "")
            steps = [
                *self._fetch(obj, source),
                Step("navigate_to", {"target": place}),
                Step("place_object", {"location": place}),
            ]
            self.held, self.last_place = None, place
            return _Said(steps, f"I have put the {obj} on the {place}.")
        if action == "go":
            target = self._target(request.place or "")
            return _Said([Step("navigate_to", {"target": target})], f"I am at {_the(target)}.")
        if action == "find":
            obj, _ = self._object(request)
            return _Said([Step("detect_object", {"object": obj})])
        if action == "say":
            if not request.text.strip():
                raise PlanningError("say what? e.g. 'say hello' or 'announce: dinner is ready'")
            return _Said([Step("say", {"text": request.text.strip().strip("\"'").strip()})])
        simple = {
            "look": _Said([Step("look_around", {})]),
            "look_and_tell": _Said([Step("look_around", {}), Step("describe_scene", {})]),
            "home": _Said([Step("go_home", {})], "I am back where I started."),
            "stop": _Said([Step("stop", {})]),
        }
        if action == "wait":
            return _Said([Step("wait", {"seconds": f"{request.seconds:g}"})])
        return simple[action]

    # --- names -----------------------------------------------------------------------------------------------

    def _object(self, request: Request) -> tuple[str, str | None]:
        phrase = (request.thing or "").strip()
        if phrase in OBJECT_PRONOUNS:
            name = self.last_object or self.held or self.earlier_object
            if name is None:
                raise PlanningError(f"which object is {phrase!r}? name it, e.g. 'the red mug'")
            source = None
        else:
            reference = self.names.object(_after_a_vague_head(phrase, self._one_object) or phrase)
            name, source = reference.name, reference.source
        if request.source:
            source = self._place(request.source)
        self.last_object = name
        return name, source

    def _place(self, phrase: str) -> str:
        if phrase.strip() in (*PLACE_PRONOUNS, *OBJECT_PRONOUNS) and self.last_place is not None:
            return self.last_place  # "the table: put the apple on it"
        place = self.names.place(phrase)
        self.last_place = place
        return place

    def _target(self, phrase: str) -> str:
        pose = parse_pose_goal(phrase)
        if pose is not None:
            return pose.text()
        if phrase.strip().lower() in PLACE_PRONOUNS and self.last_place is not None:
            return self.last_place
        target = self.names.target(phrase)
        self.last_place = target
        return target

    def _names_an_object(self, phrase: str | None) -> bool:
        try:
            self.names.object(phrase or "")
        except ClarificationNeeded:
            return True  # it names things: the question will be asked
        except PlanningError:
            return False
        return True

    def _topic(self, phrase: str) -> None:
        """A thing named on its own before the request about it ("the red mug, bring it to the table")."""
        try:
            reference = self.names.object(phrase)
        except PlanningError as not_an_object:
            try:
                self.last_place = self.names.place(phrase)
            except PlanningError:
                raise not_an_object from None
            return
        self.last_object = reference.name

    # --- steps -----------------------------------------------------------------------------------------------

    def _fetch(self, obj: str, source: str | None) -> list[Step]:
        if self.held is not None and self.held != obj:
            raise PlanningError(f"the robot is holding the {self.held}: put it down first")
        if self.held == obj:
            return []
        where = source or self.world.object_locations.get(obj)
        if where is None:
            raise PlanningError(f"I don't know where the {obj} is; say where to pick it from")
        self.held = obj
        return [
            Step("navigate_to", {"target": where}),
            Step("detect_object", {"object": obj}),
            Step("pick_object", {"object": obj}),
        ]


# "something to drink", "anything to eat", "a drink": a thing named vaguely, which a name said after it makes one
_VAGUE_HEAD = re.compile(
    r"(?:something|anything)(?: (?:to (?:drink|eat)|for me to (?:drink|eat))(?: (?:from|out of))?)?|"
    r"(?:a |some )?(?:drink|snack|beverage|refreshment)"
)


def _after_a_vague_head(phrase: str, one_object: Callable[[str], str | None]) -> str | None:
    """ "something to drink the bottle" (a recogniser drops the comma): the name after a vague head, when that
    names one object; None otherwise (the phrase is read as it is)."""
    head = _VAGUE_HEAD.match(phrase.strip())
    if head is None:
        return None
    rest = phrase.strip()[head.end() :].strip(" ,-")
    return rest if rest and one_object(rest) is not None else None


def _any_of(items: Iterable[str]) -> str:
    """'the red mug, the blue bottle or the green apple'."""
    listed = list(items)
    return ", ".join(listed[:-1]) + f" or {listed[-1]}" if len(listed) > 1 else "".join(listed)


def _the(target: str) -> str:
    return target if target[:1].isdigit() or target[:1] == "-" else f"the {target}"


def _last_object(context: PlanningContext) -> str | None:
    """The object the newest turn of the conversation was about."""
    for turn in reversed(context.history):
        if turn.plan is None:
            continue
        for step in reversed(turn.plan.steps):
            if "object" in step.args:
                return step.args["object"]
    return None
