"""Every spoken set's sentences, typed: the labels agree with the planner, so the speech bench's misses are of
hearing, not of wording (and a set written later that the planner cannot read shows up here first); and every
voice is one espeak-ng has, each once across the held-out sets' variants."""

from __future__ import annotations

import pytest

from harness.planner_cases import context_for, plan_matches
from harness.spoken_cases import SETS
from robot.model.world import generate_world
from robot.planning.context import PlanningContext
from robot.planning.pipeline import PlannerConfig, build_pipeline
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext
from robot.speech.stop_word import ends_with_stop
from robot.speech.tts import check_variant


@pytest.fixture(scope="module")
def layout():
    return generate_world(0)


@pytest.fixture(scope="module")
def planner():
    return build_pipeline(PlannerConfig(backend="rules"))


@pytest.mark.parametrize("name", sorted(SETS))
def test_each_sentence_of_a_spoken_set_typed_plans_as_labelled_and_nothing_out_of_the_world_plans(
    name: str, layout, planner
) -> None:
    spoken = SETS[name]
    wrong = []
    for case in (*spoken.commands, *spoken.with_stop):
        try:
            result = planner.plan(case.text, context_for(case, layout))
        except PlanningError as error:
            wrong.append(f"{case.text!r}: {error}")
            continue
        if not plan_matches(case.plan, result.plan.to_seed_list()):
            wrong.append(f"{case.text!r}: {result.plan.to_seed_list()}")
    assert wrong == []
    world = PlanningContext(WorldContext.from_layout(layout))
    for request in spoken.out_of_world:
        with pytest.raises(PlanningError):
            planner.plan(request, world)


@pytest.mark.parametrize("name", sorted(SETS))
def test_a_spoken_sets_stops_are_stops_in_words_and_its_commands_with_stop_are_not(name: str) -> None:
    spoken = SETS[name]
    assert [t for t in spoken.stops if not ends_with_stop(t)] == []
    assert [c.text for c in (*spoken.commands, *spoken.with_stop) if ends_with_stop(c.text)] == []


def test_every_voice_of_the_spoken_sets_is_one_espeak_has() -> None:
    """espeak-ng speaks an unknown variant ("+annie" for "+Annie") as the plain accent without a word: such a voice
    would be no new voice at all."""
    for spoken in SETS.values():
        for voice in spoken.voices:
            check_variant(voice.name)
