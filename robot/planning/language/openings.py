"""How commands begin, and a heard sentence with its opening words swapped for an opening that looks like them.

A recogniser mishears a command's verb more than anything else in it ("Work to the charging station." for "walk to
the charging station", "Grant me the cup." for "grab me the cup", "A ounce of lunch is ready." for "announce that
lunch is ready"), and then the planner cannot read the sentence at all. `reopened_wordings` writes the sentence again
with a command's opening in place of the words that look like one; a recogniser that still has the audio keeps the
ones the audio supports (robot/speech/whisper.py), and the planner asks before running one ("did you mean ...?").
Only openings are swapped: the names after them stay as heard, so a request for something the world does not have
stays refused.
"""

from __future__ import annotations

import re
from functools import cache

from rapidfuzz import fuzz

from robot.planning.language.lexicon import FILLER_PREFIXES, word_list
from robot.planning.world_context import normalize

# What people begin a command with, in the words the planner reads. Only the common ones: each is a wording to
# score against the audio, and an announcement's opening makes any words after it readable ("proclaim be for
# remote" from "Bremby for remote." for "bring me the remote"), so only the usual ways to ask for one are here.
COMMAND_OPENINGS = word_list("""
    go to, go over to, go back to, go home, go get, walk to, walk over to, head to, head over to, head back to,
    move to, drive to, come back to, return to, return home,
    pick up, grab, get, fetch, take, bring, bring me, hand me, give me, collect,
    put, place, set, drop, carry, move, leave,
    find, locate, search for, look for, look around, have a look around,
    say, announce, announce that, tell everyone that,
    wait, wait for, pause, pause for, hold on""")
# Words a swapped opening may replace: at most this many, and only where a command or one of its steps begins
MAX_SWAPPED_WORDS = 3
# How alike (rapidfuzz's ratio of the letters, 0-100) the words replaced and the opening must be: "work to" and
# "walk to" 67, "grant" and "grab" 67, "a ounce of" and "announce" 75, "don't get" and "go get" 67.
MIN_LIKENESS = 60
_STEP_JOINS = frozenset(word_list("then, and, next"))


def reopened_wordings(text: str, limit: int = 8) -> list[str]:
    """`text` with words where a command (or a later step, after "then" or "and") begins replaced by a command's
    opening that looks like them, likeliest-looking first, at most `limit`, none the same as `text`."""
    words = normalize(text).split()
    if not words:
        return []
    starts = {0, len(words) - len(_without_filler(words))}
    starts |= {i + 1 for i, word in enumerate(words[:-1]) if word in _STEP_JOINS}
    scored: dict[str, float] = {}
    for start in sorted(starts):
        for count in range(1, MAX_SWAPPED_WORDS + 1):
            if start + count > len(words):
                break
            span = "".join(words[start : start + count])
            for opening in COMMAND_OPENINGS:
                likeness = fuzz.ratio(span, opening.replace(" ", ""))
                if likeness < MIN_LIKENESS:
                    continue
                wording = " ".join([*words[:start], opening, *words[start + count :]])
                if wording != " ".join(words) and likeness > scored.get(wording, -1.0):
                    scored[wording] = likeness
    return sorted(scored, key=lambda w: -scored[w])[:limit]


def _without_filler(words: list[str]) -> list[str]:
    """The words after any of the fillers people begin with."""
    text = " ".join(words)
    while True:
        match = _filler_prefix().match(text)
        if match is None or not match.group(0).strip():
            return text.split()
        text = text[match.end() :]


@cache
def _filler_prefix() -> re.Pattern[str]:
    fillers = sorted(FILLER_PREFIXES, key=len, reverse=True)
    return re.compile(r"^(?:" + "|".join(re.escape(f) for f in fillers) + r")(?: |$)")
