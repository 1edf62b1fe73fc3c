"""Deterministic, offline rule-based planner for the robot's action vocabulary.

It recognises the supported intents (fetch, bring to, go to, go home, find, look around, what do you see, wait,
stop, say) with their common paraphrases and resolves object and place names against the world, so an unknown
name is an error, never a guess. "it" means the object in hand, else the last one the conversation named.
"""

from __future__ import annotations

import re

from robot.interface import Plan, Step
from robot.navigation.goal import parse_pose_goal
from robot.planning.context import PlanningContext
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext, normalize

_PICK = r"(?:pick up|pick|grab|take|get|fetch|grasp|lift|collect|retrieve)"
_BRING = r"(?:bring|carry|deliver|move|take|put|place|set|drop|leave|bring back|take back)"
_GO = r"(?:go|navigate|walk|move|head|drive|return|come|proceed|travel)"
_FIND = r"(?:find|look for|search for|detect|locate|where is|where s|spot|can you see|do you see|is there)"
_ARTICLE = r"(?:the |a |an |my |your |that |this |some )?"
_PRONOUNS = ("it", "that", "this", "that one", "this one", "the object", "them")
_POLITE = r"^(?:please |robot |hey robot |ok robot |okay robot |now |can you |could you |would you |will you |go and )+"
# what `wait` understands, and what speech recognition listens for
NUMBER_WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
                "nine": 9, "ten": 10, "fifteen": 15, "twenty": 20, "thirty": 30, "a few": 3,
                "a couple of": 2}  # fmt: skip
_STOP = re.compile(
    r"(?:please )?(?:stop|halt|freeze|stand still|stop moving|stop now|cancel|abort|stop everything|"
    r"emergency stop|stop what you are doing|stop it)(?: please| now)?"
)
_WHAT_DO_YOU_SEE = re.compile(
    r"(?:what|which objects|what things) (?:do|can) you see(?: around you| here)?|what is around(?: you)?|"
    r"what s around(?: you)?|describe (?:the scene|what you see|your surroundings)|tell me what you see|"
    r"report what you see|what have you seen"
)

EXAMPLES = (
    "'pick up the red mug from the kitchen counter', 'bring the red mug to the living-room table', "
    "'go to the charging dock', 'find the green apple', 'what do you see', 'go home', 'wait 5 seconds', 'stop' "
    "or 'say hello'"
)


class RulesPlanner:
    name = "rules"

    def describe(self) -> str:
        return "built-in rules (offline)"

    def plan(self, text: str, context: PlanningContext) -> Plan:
        raw = text.strip()
        if not raw:
            raise PlanningError("empty command")
        world = context.world
        said = re.match(r"^\s*(?:please\s+)?(?:say|speak|tell me|announce)\s*[:,]?\s+(.+)$", raw, re.IGNORECASE)
        if said and normalize(said.group(1)) not in ("what you see", "what do you see", "what you can see"):
            return Plan((Step("say", {"text": said.group(1).strip().strip("\"'")}),))

        # "go to 1.2, 0.5", "walk to (1.2, 0.5, 90 deg)": a pose on the map (punctuation matters here)
        m = re.match(rf"^\s*(?:please\s+)?{_GO}\s+(?:to\s+)?(.+)$", raw, re.IGNORECASE)
        pose = parse_pose_goal(m.group(1)) if m else None
        if pose is not None:
            return Plan((Step("navigate_to", {"target": pose.text()}),
                         Step("say", {"text": f"I am at {pose.text()}."})))  # fmt: skip

        t = normalize(raw)
        if _STOP.fullmatch(t):
            return Plan((Step("stop", {}),))
        t = re.sub(_POLITE, "", t)
        t = re.sub(r" (?:please|for me|now|right now|thanks|thank you)$", "", t)

        plan = self._simple_intent(t, world)
        if plan is not None:
            return plan

        # "bring the red mug to the living-room table", "put the apple on the table", "put it on the table"
        m = re.match(
            rf"^{_BRING} {_ARTICLE}(.+?)(?: (?:from|off) {_ARTICLE}(.+?))?(?: back| over| down)? "
            rf"(?:to|onto|on|into|in|at|over to|on to|back to|down on) {_ARTICLE}(.+)$",
            t,
        )
        if m:
            obj = self._object(m.group(1), context)
            destination = m.group(3)
            if destination in ("me", "here", "us", "me here"):
                return self._fetch(obj, m.group(2), world, then_say=f"Here is the {obj}.")
            place = self._place(destination, world)
            return self._carry(obj, m.group(2), place, world)

        # "bring the apple here", "bring it over here"
        m = re.match(rf"^(?:bring|fetch|get|carry) {_ARTICLE}(.+?) (?:over )?here$", t)
        if m:
            obj = self._object(m.group(1), context)
            return self._fetch(obj, None, world, then_say=f"Here is the {obj}.")

        # "bring me the apple", "i want the mug", "can i have the bottle"
        m = re.match(
            rf"^(?:(?:bring|fetch|get|hand|give|pass) me|i want|i need|i would like|i d like|can i have|may i have)"
            rf" {_ARTICLE}(.+?)(?: (?:from|off) {_ARTICLE}(.+))?$",
            t,
        )
        if m:
            obj = self._object(m.group(1), context)
            return self._fetch(obj, m.group(2), world, then_say=f"Here is the {obj}.")

        # "pick up the red mug from the kitchen counter", "grab the red cup off the counter"
        m = re.match(rf"^{_PICK}(?: up)? {_ARTICLE}(.+?)(?: (?:up )?(?:from|off|on|at) {_ARTICLE}(.+))?(?: up)?$", t)
        if m:
            obj = self._object(m.group(1), context)
            return self._fetch(obj, m.group(2), world, then_say=f"I have picked up the {obj}.")

        # "go to the dock", "head over to the kitchen", "walk to the mug"
        m = re.match(rf"^{_GO}(?: back| over)? (?:to|towards|over to|into|in to) {_ARTICLE}(.+)$", t)
        if m:
            target = world.resolve_place(m.group(1))
            thing = world.resolve_object(m.group(1)) if target is None else None
            if thing is not None:
                target = self._source(thing, None, world)
            if target is None:
                raise PlanningError(f"unknown place {m.group(1)!r}; known places: {', '.join(world.places)}")
            return Plan((Step("navigate_to", {"target": target}), Step("say", {"text": f"I am at the {target}."})))

        # "find the apple", "where is the bottle", "look for the mug"
        m = re.match(rf"^{_FIND} {_ARTICLE}(.+?)(?: anywhere| around| here)?$", t)
        if m:
            return Plan((Step("detect_object", {"object": self._object(m.group(1), context)}),))

        raise PlanningError(f"I don't understand {raw!r}. Try e.g. {EXAMPLES}.")

    # --- intents without objects --------------------------------------------------------------------------------

    def _simple_intent(self, t: str, world: WorldContext) -> Plan | None:
        if _WHAT_DO_YOU_SEE.fullmatch(t):
            return Plan((Step("look_around", {}), Step("describe_scene", {})))
        if re.fullmatch(r"(?:look around|have a look around|scan the room|scan around|look about)", t):
            return Plan((Step("look_around", {}),))
        if re.fullmatch(r"(?:go|return|walk|head|come)(?: back)? (?:home|to your start|to where you started|"
                        r"to the start|to your starting (?:point|position)|to base)|home|go home", t):  # fmt: skip
            return Plan((Step("go_home", {}), Step("say", {"text": "I am back where I started."})))
        m = re.fullmatch(r"(?:wait|pause|hold on|stay(?: still| there| here)?|stand by)(?: for)? (.+?)"
                         r" ?(?:seconds|second|secs|sec|s)", t)  # fmt: skip
        if m:
            seconds = _number(m.group(1))
            if seconds is None:
                raise PlanningError(f"how long is {m.group(1)!r} seconds?")
            return Plan((Step("wait", {"seconds": f"{seconds:g}"}),))
        return None

    # --- helpers --------------------------------------------------------------------------------------------

    def _object(self, phrase: str, context: PlanningContext) -> str:
        world = context.world
        if phrase in _PRONOUNS:
            name = world.held_object or _last_object(context)
            if name is None:
                raise PlanningError(f"which object is {phrase!r}? name it, e.g. 'the red mug'")
            return name
        name = world.resolve_object(phrase)
        if name is None:
            raise PlanningError(f"unknown object {phrase!r}; known objects: {', '.join(world.objects)}")
        return name

    def _place(self, phrase: str, world: WorldContext) -> str:
        name = world.resolve_place(phrase)
        if name is None:
            raise PlanningError(f"unknown place {phrase!r}; known places: {', '.join(world.places)}")
        return name

    def _source(self, obj: str, source_phrase: str | None, world: WorldContext) -> str:
        believed = world.object_locations.get(obj)
        if source_phrase is None:
            if believed is None:
                raise PlanningError(f"I don't know where the {obj} is; say where to pick it from")
            return believed
        return self._place(source_phrase, world)

    def _fetch(self, obj: str, source_phrase: str | None, world: WorldContext, then_say: str | None) -> Plan:
        steps: list[Step] = []
        if world.held_object is not None and world.held_object != obj:
            raise PlanningError(f"the robot is holding the {world.held_object}: put it down first")
        if world.held_object != obj:
            source = self._source(obj, source_phrase, world)
            steps += [
                Step("navigate_to", {"target": source}),
                Step("detect_object", {"object": obj}),
                Step("pick_object", {"object": obj}),
            ]
        steps.append(Step("say", {"text": then_say or f"Here is the {obj}."}))
        return Plan(tuple(steps))

    def _carry(self, obj: str, source_phrase: str | None, place: str, world: WorldContext) -> Plan:
        steps = list(self._fetch(obj, source_phrase, world, then_say=None).steps[:-1])
        steps += [
            Step("navigate_to", {"target": place}),
            Step("place_object", {"location": place}),
            Step("say", {"text": f"I have put the {obj} on the {place}."}),
        ]
        return Plan(tuple(steps))


def _last_object(context: PlanningContext) -> str | None:
    """The object the newest turn of the conversation was about."""
    for turn in reversed(context.history):
        if turn.plan is None:
            continue
        for step in reversed(turn.plan.steps):
            if "object" in step.args:
                return step.args["object"]
    return None


def _number(text: str) -> float | None:
    text = text.strip()
    if text in NUMBER_WORDS:
        return float(NUMBER_WORDS[text])
    try:
        return float(text)
    except ValueError:
        return None
