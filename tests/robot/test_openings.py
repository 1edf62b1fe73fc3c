"""A heard sentence written again with a command's opening in place of words that look like one."""

from __future__ import annotations

import pytest

from robot.planning.language.openings import COMMAND_OPENINGS, reopened_wordings


@pytest.mark.parametrize(
    ("heard", "meant"),
    [
        ("Work to the charging station.", "walk to the charging station"),
        ("Grant me the cup, please.", "grab me the cup please"),
        ("A ounce of lunch is ready.", "announce that lunch is ready"),
        ("Don't get it!", "go get it"),
        ("Okay robot, what to the counter?", "okay robot walk to the counter"),  # after the words people say first
        ("Look around, then work to the dock.", "look around then walk to the dock"),  # a later step
    ],
)
def test_a_misheard_opening_is_written_again_as_the_command_it_looks_like(heard: str, meant: str) -> None:
    assert meant in reopened_wordings(heard)


@pytest.mark.parametrize("heard", ["Order a pizza.", "Bring me the remote.", "Fold my shirts.", "Dance for me!"])
def test_only_the_opening_is_swapped_so_what_the_world_lacks_is_still_asked_for(heard: str) -> None:
    last = heard.lower().rstrip(".!").split()[-1]
    assert all(w.split()[-1] == last for w in reopened_wordings(heard))


def test_nothing_like_an_opening_gives_no_wording_and_the_heard_one_is_never_given_back() -> None:
    assert reopened_wordings("") == []
    assert reopened_wordings("Xyzzy plugh.") == []
    assert "walk to the dock" not in reopened_wordings("Walk to the dock.")
    assert len(reopened_wordings("Go to the dock.", limit=2)) <= 2
    assert all(o == o.lower().strip() and "  " not in o for o in COMMAND_OPENINGS)
