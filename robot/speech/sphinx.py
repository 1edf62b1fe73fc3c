"""PocketSphinx (its wheel carries the US English model), listening for the command grammar first and for free
speech when the grammar finds no whole sentence.

Confidence of a grammar sentence: how well the grammar's path explains the sound compared with an unconstrained
phone loop over the same audio (a log-likelihood ratio per second of speech, 0 when the grammar path is as good
as any). A grammar always yields some sentence of its own, even for speech it does not contain; the ratio is what
tells the two apart. Measured on espeak-ng voices: commands -0.02 to -0.10 clean, down to -0.18 at 10 dB SNR;
other speech -0.15 to -0.29. `confidence = 1 + ratio / 0.25`, clipped to 0..1. Over 70 commands in 3 voices
(figures in the README): half of the clean ones heard right reach 0.7, none of 30 sentences that are
no command do (max 0.69). Free speech (no grammar sentence) gets half: the operator confirms it.
"""

from __future__ import annotations

import math
import tempfile
import threading
import time
from pathlib import Path

from robot.speech.asr import ASRError, Transcript
from robot.speech.audio import Audio
from robot.speech.denoise import denoise
from robot.speech.grammar import Grammar, build_grammar

AUTO_RUN_CONFIDENCE = 0.7  # at or above: a command may run without the operator confirming it (a setting)
RATIO_SPAN = 0.25  # log-likelihood ratio per second that maps to confidence 0
FREE_SPEECH_SCALE = 0.5
FRAMES_PER_S = 100.0


class PocketSphinxASR:
    name = "pocketsphinx"

    def __init__(self, objects: dict[str, tuple[str, ...]], places: dict[str, tuple[str, ...]],
                 free_speech: bool = True) -> None:  # fmt: skip
        try:
            import pocketsphinx
        except ImportError as exc:
            raise ASRError("pocketsphinx is not installed (pip install pocketsphinx)") from exc
        model = Path(pocketsphinx.get_model_path()) / "en-us"
        vocabulary = {line.split(maxsplit=1)[0] for line in (model / "cmudict-en-us.dict").open() if line.strip()}
        self.grammar: Grammar = build_grammar(objects, places, vocabulary)
        # the decoder reads the grammar from a file (inline text crashed it)
        self._dir = tempfile.TemporaryDirectory(prefix="humanoid-asr-")
        grammar_path = self.grammar.write(Path(self._dir.name) / "commands.gram")
        # Whole utterances: normalise the cepstrum over each one (cmn batch), dither espeak's digital silence, and
        # take the search's best path (the lattice rescoring lost 1 command in 7 to a partial sentence).
        options = {"loglevel": "FATAL", "dither": True, "seed": 1, "cmn": "batch", "bestpath": False}
        self._commands = pocketsphinx.Decoder(jsgf=str(grammar_path), **options)
        self._free = pocketsphinx.Decoder(**options) if free_speech else None
        self._phones = pocketsphinx.Decoder(allphone=str(model / "en-us-phone.lm.bin"), lw=2.0, **options)
        self._lock = threading.Lock()  # a decoder decodes one utterance at a time

    def transcribe(self, audio: Audio) -> Transcript:
        started = time.perf_counter()
        pcm = Audio(denoise(audio.samples)).pcm()  # steady noise out first: 21.9 -> 14.8 % word errors at 10 dB
        with self._lock:
            text, score, frames = _decode(self._commands, pcm)
            _, loop_score, _ = _decode(self._phones, pcm)
            confidence = _confidence(score, loop_score, frames)
            if text and self.grammar.accepts(text):
                return Transcript(text, confidence, self.name, True, audio.duration_s, time.perf_counter() - started)
            text, score = "", None
            if self._free is not None:
                text, score, frames = _decode(self._free, pcm)
        confidence = FREE_SPEECH_SCALE * _confidence(score, loop_score, frames) if text else 0.0
        return Transcript(text, confidence, self.name, False, audio.duration_s, time.perf_counter() - started)


def _decode(decoder, pcm: bytes) -> tuple[str, float | None, int]:
    """(words, path score as a likelihood, frames). The binding gives the score already exponentiated."""
    decoder.start_utt()
    decoder.process_raw(pcm, full_utt=True)
    decoder.end_utt()
    hyp = decoder.hyp()
    if hyp is None:
        return "", None, decoder.n_frames()
    return " ".join(hyp.hypstr.split()), float(hyp.score), decoder.n_frames()


def _confidence(score: float | None, loop_score: float | None, frames: int) -> float:
    if not score or not loop_score or frames <= 0:
        return 0.0
    ratio_per_s = math.log(score / loop_score) / (frames / FRAMES_PER_S)
    return min(1.0, max(0.0, 1.0 + ratio_per_s / RATIO_SPAN))
