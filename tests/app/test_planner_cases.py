"""The rules planner against the paraphrase suite: every command gives its expected plan, validated."""

from __future__ import annotations

import pytest

from harness.planner_cases import CASES, Case, context_for, plan_matches
from robot.model.world import generate_world
from robot.planning.pipeline import PlannerConfig, build_pipeline

LAYOUT = generate_world(0)


def test_the_suite_is_large_enough_to_judge_a_planner() -> None:
    assert len(CASES) >= 60
    assert len({c.text.lower() for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.text)
def test_rules_gives_the_expected_plan(case: Case) -> None:
    result = build_pipeline(PlannerConfig(backend="rules")).plan(case.text, context_for(case, LAYOUT))
    assert result.planner == "rules"
    assert plan_matches(case.plan, result.plan.to_seed_list()), result.plan.to_seed_list()


def test_a_wrong_plan_does_not_match() -> None:
    case = CASES[0]
    wrong = [dict(step) for step in case.plan]
    wrong[2]["object"] = "green apple"
    assert not plan_matches(case.plan, wrong)
    assert not plan_matches(case.plan, case.plan[:-1])
    silent = [dict(step) for step in case.plan]
    silent[-1]["text"] = " "
    assert not plan_matches(case.plan, silent)


def test_a_said_text_matches_however_it_is_spelt_aloud_but_not_other_words() -> None:
    """The robot says "goodnight" and "good night" alike (whisper writes the one for the other)."""
    expected = [{"action": "say", "text": "good night"}]
    assert plan_matches(expected, [{"action": "say", "text": "Goodnight!"}])
    assert plan_matches(expected, [{"action": "say", "text": "Good-night."}])
    assert not plan_matches(expected, [{"action": "say", "text": "good light"}])
    # a comma inside is not said ("Say hello, everybody!" as whisper writes it), but the words still count
    hello = [{"action": "say", "text": "hello everybody"}]
    assert plan_matches(hello, [{"action": "say", "text": "hello, everybody"}])
    assert not plan_matches(hello, [{"action": "say", "text": "hello every party"}])
    assert not plan_matches([{"action": "wait", "seconds": "2.5"}], [{"action": "wait", "seconds": "25"}])
