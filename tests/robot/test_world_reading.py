"""A transcript read against the world: when the recogniser's first wording is no command of this world and another
of its wordings is, that one is the transcript, never sure, with the first heard kept."""

from __future__ import annotations

import pytest

from robot.model.world import generate_world
from robot.planning.heard import WorldReader
from robot.planning.world_context import WorldContext
from robot.speech.asr import Transcript
from robot.speech.world_reading import read_in_world


@pytest.fixture(scope="module")
def read():
    return WorldReader(WorldContext.from_layout(generate_world(0))).read


def heard(text: str, *alternatives: str, confidence: float = 0.9) -> Transcript:
    return Transcript(text, confidence, "whisper", False, 1.5, 0.4, alternatives=alternatives)


def test_a_first_wording_no_command_gives_way_to_the_likeliest_that_is_one(read) -> None:
    first = heard("Go to your phone position.", "Go to the phone position.", "Go to your home position.", "Go home.")
    assert first.sure
    t = read_in_world(first, read)
    assert t.text == "Go to your home position." and t.first_heard == "Go to your phone position."
    assert not t.sure  # the operator sends it, as they would answer "did you mean ...?"
    assert t.alternatives == ("Go to your phone position.", "Go to the phone position.", "Go home.")


def test_a_transcript_that_plans_is_kept(read) -> None:
    plans = heard("Hand me the bottle.", "Handle the bottle.")
    assert read_in_world(plans, read) == plans


def test_a_question_gives_way_only_to_a_wording_that_plans_one_of_its_readings(read) -> None:
    """Whisper hears "i want the green apple" as "I want the red apple." (heldout22: the green apple or the red
    mug?) with "I want a green apple." next: the audio answers the question."""
    question = read("I want the red apple.")
    assert question.kind == "asks" and question.names == {"green apple", "red mug"}
    red = heard("I want the red apple.", "I want the blue apple.", "I want a green apple.", "I want the red mug.")
    t = read_in_world(red, read)
    assert t.text == "I want a green apple." and t.first_heard == "I want the red apple." and not t.sure
    # a wording that plans something the question did not offer does not answer it
    unrelated = heard("I want the red apple.", "Go to the dock.", "Find the bottle.")
    assert read_in_world(unrelated, read) == unrelated


def test_what_is_not_in_the_world_stays_as_heard(read) -> None:
    cat = heard("Feed the cat.", "Feed the cap.", "Sing happy birthday.", "Fetch the car.")
    assert read_in_world(cat, read) == cat  # none of them is a command here: refused as heard
    assert read_in_world(heard("Thank you."), read).text == "Thank you."  # nothing else heard


def test_a_wording_needing_something_in_the_hand_reads(read) -> None:
    t = read_in_world(heard("Place it on the tape, you know.", "Place it on the table."), read)
    assert t.text == "Place it on the table."


def test_no_stop_is_made_of_a_command_and_a_stop_is_left_to_the_spoken_stop(read) -> None:
    # the first wording is no stop; a stop further down is for the spoken stop's rules, not for this
    assert read("Stop.").kind == "plans"
    near = heard("Shop at the store.", "Stop.", "Stop at the store.")
    assert read_in_world(near, read).text == "Shop at the store."
    stop = heard("Stop right now.", "Go to the dock.")
    assert read_in_world(stop, read) == stop


def test_wordings_in_other_scripts_are_not_taken(read) -> None:
    t = read_in_world(heard("Gah to the dak.", "ゴー・トゥ・ザ・ドック", "Go to the dock."), read)
    assert t.text == "Go to the dock."


def test_the_prompt_said_back_is_never_the_reading(read) -> None:
    """Whisper's prompt is made of commands, so its echoes always read: "Head to the charging dock." for "have a look
    around" (heldout22) must not become the transcript."""
    first = heard("Have a look at the mold.", "Have a look at the mood.", "Head to the charging dock.", confidence=0.1)
    echoed = Transcript(**{**first.__dict__, "prompt_echoes": ("Head to the charging dock.",)})
    assert read_in_world(echoed, read) == echoed
    assert read_in_world(first, read).text == "Head to the charging dock."  # as any command would be, unmarked
