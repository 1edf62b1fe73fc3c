"""The rules planner on commands in everyday wording: the development set case by case, and the held-out set
against the issue's bars (a regression guard: the planner is never tuned on it)."""

from __future__ import annotations

from collections import Counter

import pytest

from harness.language_cases import BARS, CLARIFY, MUG, REFUSE, LanguageCase, Outcome, fetch, go, plan_case, say, seq
from harness.language_dev import DEV
from harness.language_heldout import HELDOUT
from harness.planner_cases import COUNTER, TABLE, normalise_text
from robot.model.world import generate_world
from robot.planning.pipeline import PlannerConfig, build_pipeline

LAYOUT = generate_world(0)
PIPELINE = build_pipeline(PlannerConfig(backend="rules"))
KINDS_OF_EVERYDAY_WORDING = {
    "polite",
    "walk noun",
    "place description",
    "sequence",
    "pronoun",
    "announcement",
    "object first",
    "near miss",
}


@pytest.mark.parametrize("cases", [DEV, HELDOUT], ids=["dev", "heldout"])
def test_each_set_covers_what_the_issue_asks_for(cases: tuple[LanguageCase, ...]) -> None:
    kinds = Counter(c.kind for c in cases)
    assert kinds["everyday"] >= 60 and kinds["paraphrase"] >= 20 and kinds["out_of_world"] >= 20
    assert {c.topic for c in cases if c.kind == "everyday"} >= KINDS_OF_EVERYDAY_WORDING
    assert {"unknown object", "unknown place", "unknown ability"} <= {
        c.topic for c in cases if c.kind == "out_of_world"
    }
    assert len({normalise_text(c.text) for c in cases}) == len(cases)


def test_the_held_out_set_shares_no_command_with_the_development_set() -> None:
    assert not {normalise_text(c.text) for c in DEV} & {normalise_text(c.text) for c in HELDOUT}


@pytest.mark.parametrize("case", DEV, ids=lambda c: c.text)
def test_the_development_set(case: LanguageCase) -> None:
    outcome = plan_case(PIPELINE, case, LAYOUT)
    assert outcome.right_for(case), outcome.said()


def test_the_held_out_set_meets_the_bars() -> None:
    outcomes = [(case, plan_case(PIPELINE, case, LAYOUT)) for case in HELDOUT]
    for kind, target in BARS.items():
        judged = [(case, outcome) for case, outcome in outcomes if case.kind == kind]
        wrong = [(case.text, outcome.said()) for case, outcome in judged if not outcome.right_for(case)]
        assert judged and 1 - len(wrong) / len(judged) >= target, wrong


def test_a_question_or_a_refusal_where_a_plan_was_expected_is_a_miss() -> None:
    wants_plan = LanguageCase("everyday", "polite", "could you get the cup", fetch(MUG))
    assert not Outcome(question="Did you mean the red mug or the blue bottle?").right_for(wants_plan)
    assert not Outcome(refusal="unknown object 'cup'").right_for(wants_plan)
    assert Outcome(plan=[*fetch(MUG)[:-1], {"action": "say", "text": "Here it is."}]).right_for(wants_plan)
    out_of_world = LanguageCase("out_of_world", "unknown object", "bring me the banana", REFUSE)
    assert not Outcome(plan=fetch(MUG)).right_for(out_of_world)
    assert not Outcome(question="Did you mean the green apple?").right_for(out_of_world)
    ambiguous = LanguageCase("clarify", "two readings", "bring me the blue mug", CLARIFY)
    assert not Outcome(refusal="no").right_for(ambiguous)


def test_a_sequence_is_labelled_without_the_confirmations_of_its_earlier_steps() -> None:
    assert seq(go(COUNTER), say("hi"), go(TABLE)) == [
        {"action": "navigate_to", "target": COUNTER},
        {"action": "say", "text": "hi"},  # asked for: kept
        {"action": "navigate_to", "target": TABLE},
        {"action": "say", "text": "*"},
    ]
    assert seq(go(COUNTER), fetch(MUG)) == fetch(MUG)  # already at the counter: no second walk there
