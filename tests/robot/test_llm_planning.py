"""LLM planning: reading a model's reply, repairing an invalid plan, falling back to the rules planner with the
reason kept, and the prompt carrying the world and the conversation."""

from __future__ import annotations

import json
from typing import Any

import pytest

from robot.interface import KnownObject, Plan, Step
from robot.planning import prompt
from robot.planning.context import ConversationMemory, PlanningContext, Turn
from robot.planning.llm import LLMPlanner, parse_plan_text
from robot.planning.pipeline import PlannerConfig, PlanningPipeline, build_pipeline
from robot.planning.planner import PlanningError
from robot.planning.rules import RulesPlanner
from robot.planning.validator import validate_plan_json
from robot.planning.world_context import WorldContext

FETCH = [
    {"action": "navigate_to", "target": "kitchen counter"},
    {"action": "detect_object", "object": "red mug"},
    {"action": "pick_object", "object": "red mug"},
    {"action": "say", "text": "Got it."},
]


class ScriptedModel:
    """A chat model that answers from a script and records what it was asked."""

    name = "openai"

    def __init__(self, *answers: str | Exception) -> None:
        self.answers = list(answers)
        self.asked: list[list[prompt.Message]] = []

    def describe(self) -> str:
        return "scripted"

    def chat(self, messages: list[prompt.Message], schema: dict[str, Any]) -> str:
        self.asked.append(messages)
        answer = self.answers.pop(0)
        if isinstance(answer, Exception):
            raise answer
        return answer


@pytest.fixture
def context(layout) -> PlanningContext:
    return PlanningContext(WorldContext.from_layout(layout))


@pytest.mark.parametrize(
    "reply",
    [
        json.dumps({"steps": FETCH}),
        json.dumps(FETCH),
        "```json\n" + json.dumps({"steps": FETCH}) + "\n```",
        "Here is the plan: " + json.dumps({"steps": FETCH}) + " Hope it helps.",
    ],
)
def test_a_plan_is_read_from_the_shapes_models_reply_in(context, reply: str) -> None:
    plan = LLMPlanner(ScriptedModel(reply)).plan("pick up the red mug", context)
    assert [s.action for s in plan.steps] == ["navigate_to", "detect_object", "pick_object", "say"]
    assert plan.steps[2].args == {"object": "red mug"}


def test_a_reply_without_json_says_so() -> None:
    with pytest.raises(PlanningError, match="not JSON"):
        parse_plan_text("I cannot do that, Dave.")


def test_an_invalid_plan_is_asked_again_with_its_errors_and_the_repair_is_used(context) -> None:
    wrong = [{"action": "pick_object", "object": "red mug"}, {"action": "place_object", "location": "moon"}]
    model = ScriptedModel(json.dumps({"steps": wrong}), json.dumps({"steps": FETCH}))
    planner = LLMPlanner(model, max_repairs=1)
    plan = planner.plan("pick up the red mug", context)
    assert plan.steps[0].args == {"target": "kitchen counter"}
    assert len(model.asked) == 2
    repair = model.asked[1][-1]["content"]
    assert "unknown place 'moon'" in repair
    assert model.asked[1][-2] == {"role": "assistant", "content": json.dumps({"steps": wrong})}
    assert [a.errors for a in planner.last_attempts][1] == []


def test_a_model_that_stays_wrong_falls_back_to_rules_and_the_operator_sees_why(context) -> None:
    wrong = json.dumps({"steps": [{"action": "fly_to", "target": "moon"}]})
    pipeline = PlanningPipeline(LLMPlanner(ScriptedModel(wrong, wrong), 1), "openai", RulesPlanner())
    result = pipeline.plan("pick up the red mug from the kitchen counter", context)
    assert result.planner == "rules" and result.backend == "openai"
    assert result.attempts == 2
    assert "unknown action 'fly_to'" in result.notes[0]
    assert result.notes[-1] == "planned by rules instead"
    assert [s.action for s in result.plan.steps][:3] == ["navigate_to", "detect_object", "pick_object"]


def test_a_timeout_falls_back_to_rules(context) -> None:
    model = ScriptedModel(PlanningError("gpt at http://x timed out after 20 s"))
    result = PlanningPipeline(LLMPlanner(model), "openai", RulesPlanner()).plan("go to the dock", context)
    assert result.planner == "rules"
    assert "timed out after 20 s" in result.notes[0]


def test_without_a_fallback_the_models_failure_is_the_answer(context) -> None:
    model = ScriptedModel(PlanningError("cannot reach http://127.0.0.1:9/v1"))
    with pytest.raises(PlanningError, match="cannot reach"):
        PlanningPipeline(LLMPlanner(model), "openai", fallback=None).plan("go to the dock", context)


def test_when_both_fail_both_reasons_are_given(context) -> None:
    model = ScriptedModel(PlanningError("HTTP 500: boom"))
    with pytest.raises(PlanningError, match=r"HTTP 500: boom.*rules fallback: I don't understand"):
        PlanningPipeline(LLMPlanner(model), "openai", RulesPlanner()).plan("do a backflip", context)


def test_a_backend_that_cannot_be_built_leaves_rules_planning_and_says_why(context) -> None:
    pipeline = build_pipeline(PlannerConfig(backend="local", local_model_path="/nonexistent/model.gguf"))
    assert "local model file not found" in pipeline.describe()
    result = pipeline.plan("go to the dock", context)
    assert result.planner == "rules"
    assert "local backend unavailable: local model file not found" in result.notes[0]


def test_the_prompt_carries_the_world_the_conversation_and_the_failure(layout) -> None:
    known = (KnownObject("red mug", (1.64, 0.05, 0.25), "kitchen counter", 3.0, 0.9),)
    world = WorldContext.from_layout(layout, held_object=None, known_objects=known)
    history = (Turn("find the apple", Plan((Step("detect_object", {"object": "green apple"}),)), "succeeded"),)
    context = PlanningContext(
        world, history, failure="step 3 pick_object failed: grasp slipped", done=("navigate_to(kitchen counter)",)
    )
    messages = prompt.messages("pick up the red mug", context)
    assert messages[0]["role"] == "system" and "look_around" in messages[0]["content"]
    assert messages[-1]["role"] == "user"
    user = messages[-1]["content"]
    assert "red mug (also: mug, cup, red cup, coffee mug), on the kitchen counter (seen at x 1.64" in user
    assert "living-room table" in user and "the robot holds: nothing" in user
    assert '\'find the apple\': [{"action": "detect_object", "object": "green apple"}] -> succeeded' in user
    assert "grasp slipped" in user and "Already done: navigate_to(kitchen counter)" in user
    assert user.endswith("Command: pick up the red mug")


def test_worked_examples_are_earlier_chat_turns_chosen_for_the_command_and_valid_in_this_world(context) -> None:
    messages = prompt.messages("could you grab the water bottle for me", context)
    examples = messages[1:-1]
    assert [m["role"] for m in examples] == ["user", "assistant"] * (len(examples) // 2) and len(examples) >= 4
    for asked, answered in zip(examples[::2], examples[1::2], strict=True):
        steps = json.loads(answered["content"])["steps"]
        if steps[0]["action"] == "cannot":  # one example of saying no, with the reason
            assert steps[0]["reason"] and len(steps) == 1
            continue
        assert validate_plan_json(steps, context.world)[1] == [], asked
    assert "pick_object" in examples[-1]["content"]  # the closest example is a fetch, next to the command
    go_home = prompt.messages("head back to where you started", context)[1:-1]
    assert '"go_home"' in go_home[-1]["content"]


def test_a_cannot_step_is_the_models_refusal_with_its_reason(context) -> None:
    model = ScriptedModel(json.dumps({"steps": [{"action": "cannot", "reason": "there is no banana here"}]}))
    planner = LLMPlanner(model, max_repairs=1)
    with pytest.raises(PlanningError, match="openai says it cannot: there is no banana here"):
        planner.plan("bring me the banana", context)
    assert len(model.asked) == 1  # a refusal is an answer, not an error to repair


def test_the_schema_asked_of_a_model_is_the_worlds(context) -> None:
    import jsonschema

    from robot.planning.world_schema import world_plan_schema

    schema = world_plan_schema(context.world)
    validator = jsonschema.Draft202012Validator(schema)
    assert validator.is_valid({"steps": FETCH})
    assert validator.is_valid({"steps": [{"action": "navigate_to", "target": "1.20, -0.50, 90 deg"}]})
    assert validator.is_valid({"steps": [{"action": "cannot", "reason": "there is no banana here"}]})
    for wrong in (
        {"action": "pick_object", "object": "banana"},  # not in this world
        {"action": "navigate_to", "target": "garage"},
        {"action": "place_object"},  # its argument left out
        {"action": "say", "text": "hi", "object": "red mug"},  # an argument it does not take
        {"action": "wait", "seconds": 600},
        {"action": "fly"},
    ):
        assert not validator.is_valid({"steps": [wrong]}), wrong


def test_memory_keeps_the_newest_turns_with_their_plans_and_outcomes() -> None:
    memory = ConversationMemory(max_turns=2)
    for text in ("one", "two", "three"):
        memory.add(text)
    memory.update_last(plan=Plan((Step("say", {"text": "hi"}),)), outcome="succeeded")
    turns = memory.turns()
    assert [t.command for t in turns] == ["two", "three"]
    assert turns[-1].outcome == "succeeded" and turns[-1].plan is not None
    assert [t.command for t in memory.turns(exclude_last=True)] == ["two"]
