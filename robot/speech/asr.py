"""Speech recognition behind one interface: audio in, a transcript with a confidence out."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from robot.speech.audio import Audio

# At or above: a command may run without the operator confirming it ("run when sure"). Each engine's confidence is
# calibrated as how likely its transcript is to give the plan its words were meant to (see each engine).
AUTO_RUN_CONFIDENCE = 0.7
# A transcript carries at most this many other wordings: what a command may be sent with (the API's limit) and what
# the planner tries. (Whisper's two beams can give 19: the page sent them all, and more than the API's 8 of then
# was refused, stop 87.) Nine of the beams', three heard again quicker and three with a command's opening (whisper).
ALTERNATIVES_KEPT = 15


class ASRError(Exception):
    """The engine cannot run (missing package or model): the message says what to install or set."""


@dataclass(frozen=True)
class Transcript:
    text: str  # "" when nothing was recognised
    confidence: float  # 0..1: how sure the engine is (see each engine for what it means)
    engine: str
    in_grammar: bool  # a whole sentence of the command grammar (an engine without one says False)
    audio_s: float
    decode_s: float
    # Other wordings the engine found nearly as likely, likeliest first (whisper's beam): the planner tries them,
    # and asks before running one, when it cannot read `text` ("grant me the bottle" for "grab me the bottle").
    alternatives: tuple[str, ...] = ()
    # The world's names in `text` that the audio alone barely supports: the recogniser's hints put them there more
    # than the speaker did ("Bring the apple." for "bring me a towel"). The transcript is then not sure.
    unsure_names: tuple[str, ...] = ()
    # A second model heard it again, because the first was not sure: `text` is the second's, `alternatives` both's
    heard_again: bool = False
    # Wordings further down the beam than the alternatives: only the spoken stop looks at them, in a short utterance
    further_wordings: tuple[str, ...] = ()
    # The engine's likeliest wording, when `text` is another of its wordings: the likeliest that reads as a command of
    # the world, which the first did not ("Go to your home position." under "Go to your phone position."). Never
    # sure: the operator sends it, as they would answer "did you mean ...?".
    first_heard: str = ""
    # The alternatives that are only the engine's prompt said back ("Head to the charging dock."), put last when it is
    # this unsure: they read as commands by construction, so a world reading never takes one (`world_reading`)
    prompt_echoes: tuple[str, ...] = ()

    @property
    def sure(self) -> bool:
        """Sure enough to run unasked (when the operator allows it and the planner understands it)."""
        return bool(self.text) and self.confidence >= AUTO_RUN_CONFIDENCE and not self.first_heard

    @property
    def real_time_factor(self) -> float:
        return self.decode_s / self.audio_s if self.audio_s > 0 else 0.0


class SpeechRecognizer(Protocol):
    name: str

    def transcribe(self, audio: Audio) -> Transcript: ...
