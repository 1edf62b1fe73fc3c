"""Deterministic, offline rule-based planner for the seed's action vocabulary.

It recognises a handful of intents (fetch, bring to, go to, find, place, say) with their common paraphrases and
resolves object and place names against the world, so an unknown name is an error, never a guess.
"""

from __future__ import annotations

import re

from robot.interface import Plan, Step
from robot.navigation.goal import parse_pose_goal
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext, normalize

_PICK = r"(?:pick up|pick|grab|take|get|fetch|grasp|lift)"
_BRING = r"(?:bring|carry|deliver|move|take|put|place|set)"
_GO = r"(?:go|navigate|walk|move|head|drive|return)"
_FIND = r"(?:find|look for|search for|detect|locate|where is|where s|spot)"
_ARTICLE = r"(?:the |a |an |my |your )?"


class RulesPlanner:
    name = "rules"

    def plan(self, text: str, world: WorldContext) -> Plan:
        raw = text.strip()
        if not raw:
            raise PlanningError("empty command")
        said = re.match(r"^\s*(?:please\s+)?(?:say|speak|tell me|announce)\s*[:,]?\s+(.+)$", raw, re.IGNORECASE)
        if said:
            return Plan((Step("say", {"text": said.group(1).strip().strip("\"'")}),))

        # "go to 1.2, 0.5", "walk to (1.2, 0.5, 90 deg)": a pose on the map (punctuation matters here)
        m = re.match(rf"^\s*(?:please\s+)?{_GO}\s+(?:to\s+)?(.+)$", raw, re.IGNORECASE)
        pose = parse_pose_goal(m.group(1)) if m else None
        if pose is not None:
            return Plan((Step("navigate_to", {"target": pose.text()}),
                         Step("say", {"text": f"I am at {pose.text()}."})))  # fmt: skip

        t = normalize(raw)
        t = re.sub(r"^(?:please |robot |hey robot |can you |could you |would you )+", "", t)
        t = re.sub(r" (?:please|for me|now)$", "", t)

        # "bring the red mug to the living-room table", "put the apple on the table"
        m = re.match(
            rf"^{_BRING} {_ARTICLE}(.+?)(?: from {_ARTICLE}(.+?))? (?:to|onto|on|into|in|at) {_ARTICLE}(.+)$", t
        )
        if m:
            obj = self._object(m.group(1), world)
            destination = m.group(3)
            if destination in ("me", "here", "us"):
                return self._fetch(obj, m.group(2), world, then_say=f"Here is the {obj}.")
            place = self._place(destination, world)
            return self._carry(obj, m.group(2), place, world)

        # "bring me the apple"
        m = re.match(rf"^(?:bring|fetch|get|hand) me {_ARTICLE}(.+?)(?: from {_ARTICLE}(.+))?$", t)
        if m:
            return self._fetch(self._object(m.group(1), world), m.group(2), world, then_say=None)

        # "pick up the red mug from the kitchen counter", "grab the red cup off the counter"
        m = re.match(rf"^{_PICK}(?: up)? {_ARTICLE}(.+?)(?: (?:up )?(?:from|off|on|at) {_ARTICLE}(.+))?(?: up)?$", t)
        if m:
            obj = self._object(m.group(1), world)
            return self._fetch(obj, m.group(2), world, then_say=f"I have picked up the {obj}.")

        # "go to the dock"
        m = re.match(rf"^{_GO}(?: back)? (?:to|towards|over to) {_ARTICLE}(.+)$", t)
        if m:
            place = self._place(m.group(1), world)
            return Plan((Step("navigate_to", {"target": place}), Step("say", {"text": f"I am at the {place}."})))

        # "find the apple", "where is the bottle"
        m = re.match(rf"^{_FIND} {_ARTICLE}(.+)$", t)
        if m:
            obj = self._object(m.group(1), world)
            return Plan((Step("detect_object", {"object": obj}),))

        raise PlanningError(
            f"I don't understand {raw!r}. Try e.g. 'pick up the red mug from the kitchen counter', "
            "'bring the red mug to the living-room table', 'go to the charging dock', 'find the green apple' "
            "or 'say hello'."
        )

    # --- helpers --------------------------------------------------------------------------------------------

    def _object(self, phrase: str, world: WorldContext) -> str:
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
