"""Wordings that are only whisper's prompt said back.

Whisper takes the world's names in as the text said before (`world_prompt`), and on audio it cannot make out it
sometimes writes a piece of that prompt instead of what was said: "Head to the charging dock." for "head over to
the counter" and for "put the bottle on the table", "Find the green apple." for "sing happy birthday" (the twentieth
spoken set, stop 88, confidences under 0.3). Such a wording is readable, so the planner took it and never read the
wording the speaker said one or two places down. When the transcript is not sure, the wordings that are pieces of
the prompt go after the others: a command said word for word as a prompt sentence ("find the green apple") is still
planned when nothing else heard reads.

Whisper also says back a prompt sentence's opening with another ending: "Robot, could you please pick up the green
apple?" for "the bottle, take it to the dock" in a Scottish voice (the twenty-third spoken set, stop 90), whose
beam held the words said eighth. A wording that opens with ECHO_OPENING_WORDS words of a prompt sentence is an echo
too.
"""

from __future__ import annotations

import re

from robot.planning.world_context import normalize

# A piece of the prompt this long or longer is an echo: shorter ones ("the mug", "green apple") are what people say.
ECHO_MIN_WORDS = 3
# A wording opening with this many words of a prompt sentence is an echo ("robot could you please pick ...", "would
# you mind bringing the ..."): four ("head to the charging") is how people start a command.
ECHO_OPENING_WORDS = 5
_SENTENCE_END = re.compile(r"[.?!]+")


class PromptEcho:
    """Whether a wording is a piece of the prompt's command sentences, word for word (the stop words before them
    are not: "Stop! Halt!" heard is a stop, whatever the prompt says)."""

    def __init__(self, prompt: str | None, stop_sentence: str = "") -> None:
        text = prompt or ""
        if stop_sentence and text.startswith(stop_sentence):
            text = text[len(stop_sentence) :]
        self._words = normalize(text).split()
        sentences = (normalize(sentence).split() for sentence in _SENTENCE_END.split(text))
        self._openings = {tuple(words[:ECHO_OPENING_WORDS]) for words in sentences if len(words) > ECHO_OPENING_WORDS}

    def __call__(self, wording: str) -> bool:
        words = normalize(wording).split()
        if len(words) < ECHO_MIN_WORDS:
            return False
        if tuple(words[:ECHO_OPENING_WORDS]) in self._openings:
            return True
        span = len(words)
        return any(self._words[i : i + span] == words for i in range(len(self._words) - span + 1))


def echoes_last(wordings: list[str], is_echo: PromptEcho) -> list[str]:
    """The wordings in their order, those that are only the prompt said back after the others."""
    return [w for w in wordings if not is_echo(w)] + [w for w in wordings if is_echo(w)]
