"""Planning with a language model: prompt it, read its JSON, check the plan, and ask again with the errors.

The model itself is behind `ChatModel` (an OpenAI-compatible server, or llama.cpp in-process), so every backend
gets the same prompt, parsing, validation and repair.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any, Protocol

from robot.interface import Plan
from robot.planning import prompt
from robot.planning.context import PlanningContext
from robot.planning.examples import CANNOT
from robot.planning.planner import PlanningError
from robot.planning.validator import validate_plan_json
from robot.planning.world_schema import world_plan_schema


class ChatModel(Protocol):
    name: str  # the backend's name: "openai", "local"

    def describe(self) -> str:
        """Which model, where: shown to the operator."""
        ...

    def chat(self, messages: list[prompt.Message], schema: dict[str, Any]) -> str:
        """The model's reply to the messages, constrained to the JSON schema where the backend can.
        Raises PlanningError (with the reason: timeout, HTTP status, model missing) when there is no reply."""
        ...


@dataclass
class Attempt:
    """One exchange with the model, kept so the operator can see why a plan was repaired or rejected."""

    answer: str
    errors: list[str] = field(default_factory=list)


def parse_plan_text(text: str) -> Any:
    """The JSON in a model's reply: the whole reply, or the first JSON object or list in it (models wrap plans in
    code fences or a sentence despite being told not to)."""
    stripped = text.strip()
    fenced = re.search(r"```(?:json)?\s*(.*?)```", stripped, re.DOTALL)
    if fenced:
        stripped = fenced.group(1).strip()
    try:
        return json.loads(stripped)
    except json.JSONDecodeError:
        pass
    decoder = json.JSONDecoder()
    for match in re.finditer(r"[\[{]", stripped):
        try:
            value, _ = decoder.raw_decode(stripped, match.start())
        except json.JSONDecodeError:
            continue
        if isinstance(value, dict | list):
            return value
    snippet = stripped[:120] + ("..." if len(stripped) > 120 else "")
    raise PlanningError(f"the reply is not JSON: {snippet!r}")


def _raise_if_cannot(plan_json: Any, name: str) -> None:
    """A `cannot` step is the model's refusal: its reason is the answer (no repair, no plan)."""
    steps = plan_json.get("steps") if isinstance(plan_json, dict) else plan_json
    for step in steps if isinstance(steps, list) else ():
        if isinstance(step, dict) and step.get("action") == CANNOT:
            raise PlanningError(f"{name} says it cannot: {str(step.get('reason') or 'no reason given')[:200]}")


class LLMPlanner:
    """A `Planner` over a chat model, with `max_repairs` re-asks when the plan does not validate."""

    def __init__(self, model: ChatModel, max_repairs: int = 1) -> None:
        self.model = model
        self.name = model.name
        self.max_repairs = max_repairs
        self.last_attempts: list[Attempt] = []

    def describe(self) -> str:
        return self.model.describe()

    def plan(self, text: str, context: PlanningContext) -> Plan:
        messages = prompt.messages(text, context)
        schema = world_plan_schema(context.world)
        attempts: list[Attempt] = []
        self.last_attempts = attempts
        for _ in range(1 + self.max_repairs):
            answer = self.model.chat(messages, schema)
            attempt = Attempt(answer)
            attempts.append(attempt)
            try:
                plan_json = parse_plan_text(answer)
            except PlanningError as exc:
                attempt.errors = [str(exc)]
            else:
                _raise_if_cannot(plan_json, self.name)
                plan, attempt.errors = validate_plan_json(plan_json, context.world)
                if plan is not None:
                    return plan
            messages = prompt.repair_messages(messages, answer, attempt.errors)
        tries = len(attempts)
        raise PlanningError(
            f"{self.name} gave no valid plan in {tries} tr{'ies' if tries > 1 else 'y'}: " + "; ".join(attempt.errors)
        )
