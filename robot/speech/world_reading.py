"""A recogniser's transcript read against the world: of the wordings the audio supports, the likeliest that is a
command of this world. Whisper's first wording is often one word off a command ("Go to your phone position.",
"Handle the bottle.") while the command itself is a few places down its beam; the world's commands are the language
model a general recogniser lacks (n-best rescoring). The first wording is kept (`first_heard`), and the transcript
is then never sure: the operator sends it, as they would have answered the planner's "did you mean ...?"."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

from robot.planning.heard import MAX_ALTERNATIVES, Reading, WorldReader
from robot.planning.world_context import WorldContext
from robot.speech.asr import SpeechRecognizer, Transcript
from robot.speech.audio import Audio
from robot.speech.letters import in_latin_script
from robot.speech.stop_word import transcript_is_stop


def read_in_world(transcript: Transcript, read: Callable[[str], Reading]) -> Transcript:
    """`transcript` as it was when its text plans, when it is a spoken stop, or when none of its other wordings
    plans (or the first that does is a stop; the prompt's echoes are not read); else with the first that plans as
    its text, the first heard leading the others. A text the planner would ask about ("I want the red apple.": the
    green apple or the red mug?) gives way only to a wording that plans one of the question's readings ("I want the
    green apple."): the audio answers the question."""
    if not transcript.text or not transcript.alternatives or transcript_is_stop(transcript):
        return transcript
    first = read(transcript.text)
    if first.kind == "plans":
        return transcript
    for wording in transcript.alternatives[:MAX_ALTERNATIVES]:
        if wording in transcript.prompt_echoes or not in_latin_script(wording):
            continue
        reading = read(wording)
        if reading.kind != "plans" or (first.kind == "asks" and not reading.names & first.names):
            continue
        others = tuple(a for a in transcript.alternatives if a != wording)
        chosen = replace(transcript, text=wording, alternatives=(transcript.text, *others), first_heard=transcript.text)
        # a stop the first wording was not ("Stop." under "Stop it, not") is the spoken stop's to hear, not this
        return transcript if transcript_is_stop(chosen) else chosen
    return transcript


class WorldReadRecognizer:
    """A recogniser whose transcripts are read against the world (see `read_in_world`)."""

    def __init__(self, recognizer: SpeechRecognizer, world: WorldContext) -> None:
        self.name = recognizer.name
        self.recognizer = recognizer
        self._reader = WorldReader(world)

    def transcribe(self, audio: Audio) -> Transcript:
        """The engine's transcript, read against the world; its decoding time includes the reading's."""
        heard = self.recognizer.transcribe(audio)
        started = time.perf_counter()
        read = read_in_world(heard, self._reader.read)
        return replace(read, decode_s=heard.decode_s + time.perf_counter() - started)

    def close(self) -> None:
        if hasattr(self.recognizer, "close"):
            self.recognizer.close()
