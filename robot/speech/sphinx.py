"""PocketSphinx (its wheel carries the US English model), listening for the command grammar first and for free
speech when the grammar finds no whole sentence.

Confidence of a grammar sentence: how well the grammar's path explains the sound compared with an unconstrained
phone loop over the same audio (a log-likelihood ratio per second of speech). A grammar always yields some
sentence of its own, even for speech it does not contain; the ratio is what tells the two apart. Measured on
espeak-ng voices (2 voices, 70 commands and 15 sentences that are none), with the grammar's wide beams (which
lower every ratio by about 0.08): commands heard right, quartiles -0.18, -0.14, -0.09 clean (-0.17, -0.15, -0.11
at 10 dB SNR); other speech median -0.31, max -0.18 (at 10 dB -0.26, max -0.17).
`confidence = 1 + (ratio - RATIO_AT_FULL) / RATIO_SPAN`, clipped to 0..1: a command heard right scores 0.77 at
the median, other speech at most 0.59 (0.63 at 10 dB). Free speech (no grammar sentence) gets half: the operator
confirms it.
"""

from __future__ import annotations

import math
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from robot.speech.asr import ASRError, Transcript
from robot.speech.audio import Audio
from robot.speech.denoise import denoise, snr_db
from robot.speech.grammar import Grammar, build_grammar

RATIO_AT_FULL = -0.08  # log-likelihood ratio per second that maps to confidence 1
RATIO_SPAN = 0.25  # ... and this much below it, to 0
FREE_SPEECH_SCALE = 0.5
FRAMES_PER_S = 100.0
# A noisy utterance is decoded twice, the second pass keeping the state the first left in the decoder: in noise
# that made fewer errors (70 commands x 4 voices at 10 dB, two noise seeds: word errors 13.4 -> 10.4 % and
# 12.2 -> 11.0 %, plan right 86.8 -> 90.0 % and 87.9 -> 89.6 %; clean speech gained nothing). Why it helps is not
# understood (the cepstral mean it leaves is not it: setting that alone changed nothing); it costs one more pass.
NOISY_BELOW_SNR_DB = 25.0


def grammar_decoder(grammar: Grammar, **options: Any) -> Any:
    """A pocketsphinx decoder searching `grammar`'s sentences.

    Wider beams than the default: in noise the right sentence was often pruned early (70 commands x 4 voices at
    10 dB, noise filtered: word errors 12.8 -> 9.8 %, plan right 87.1 -> 90.0 %; decoding p50 101 -> 135 ms); the
    grammar is small, so the wider search stays cheap. The decoder reads the grammar from a file (inline text
    crashed it), once, as it is built: the file's folder goes at once (kept for the decoder's life, one was left in
    the temporary folder by every robot process that was killed)."""
    import pocketsphinx

    with tempfile.TemporaryDirectory(prefix="humanoid-asr-") as folder:
        path = grammar.write(Path(folder) / "commands.gram")
        return pocketsphinx.Decoder(jsgf=str(path), beam=1e-80, wbeam=1e-60, pbeam=1e-80, **options)


def phone_loop_decoder(**options: Any) -> Any:
    """A pocketsphinx decoder over a free loop of English phones: how well any speech can be explained, against
    which a grammar sentence's fit is measured."""
    import pocketsphinx

    model = Path(pocketsphinx.get_model_path()) / "en-us"
    return pocketsphinx.Decoder(allphone=str(model / "en-us-phone.lm.bin"), lw=2.0, **options)


def fit_per_s(score: float | None, loop_score: float | None, frames: int) -> float | None:
    """How much better (above 0) or worse a sentence's path explains the sound than the phone loop's: the
    log-likelihood ratio per second of audio (None without both paths)."""
    if not score or not loop_score or frames <= 0:
        return None
    return math.log(score / loop_score) / (frames / FRAMES_PER_S)


class PocketSphinxASR:
    name = "pocketsphinx"

    def __init__(
        self, objects: dict[str, tuple[str, ...]], places: dict[str, tuple[str, ...]], free_speech: bool = True
    ) -> None:
        try:
            import pocketsphinx
        except ImportError as exc:
            raise ASRError("pocketsphinx is not installed (pip install pocketsphinx)") from exc
        model = Path(pocketsphinx.get_model_path()) / "en-us"
        vocabulary = {line.split(maxsplit=1)[0] for line in (model / "cmudict-en-us.dict").open() if line.strip()}
        self.grammar: Grammar = build_grammar(objects, places, vocabulary)
        # Whole utterances: normalise the cepstrum over each one (cmn batch; dithered here, see _dither), and
        # take the search's best path (the lattice rescoring lost 1 command in 7 to a partial sentence).
        options = {"loglevel": "FATAL", "dither": False, "cmn": "batch", "bestpath": False}
        self._commands = grammar_decoder(self.grammar, **options)
        self._free = pocketsphinx.Decoder(**options) if free_speech else None
        self._phones = phone_loop_decoder(**options)
        self._lock = threading.Lock()  # a decoder decodes one utterance at a time

    def command_sentence(self, audio: Audio) -> str:
        """The grammar's sentence for the utterance alone ("" when it finds none): no confidence, no free speech."""
        pcm = Audio(_dither(denoise(audio.samples))).pcm()
        noisy = snr_db(audio.samples) < NOISY_BELOW_SNR_DB
        with self._lock:
            text, _, _ = _decode(self._commands, pcm, passes=2 if noisy else 1)
        return text if text and self.grammar.accepts(text) else ""

    def transcribe(self, audio: Audio) -> Transcript:
        started = time.perf_counter()
        # steady noise out first (21.9 -> 14.8 % word errors at 10 dB), then the same dither for every utterance
        pcm = Audio(_dither(denoise(audio.samples))).pcm()
        noisy = snr_db(audio.samples) < NOISY_BELOW_SNR_DB
        with self._lock:
            text, score, frames = _decode(self._commands, pcm, passes=2 if noisy else 1)
            _, loop_score, _ = _decode(self._phones, pcm)
            confidence = _confidence(score, loop_score, frames)
            if text and self.grammar.accepts(text):
                return Transcript(text, confidence, self.name, True, audio.duration_s, time.perf_counter() - started)
            text, score = "", None
            if self._free is not None:
                text, score, frames = _decode(self._free, pcm)
        confidence = FREE_SPEECH_SCALE * _confidence(score, loop_score, frames) if text else 0.0
        return Transcript(text, confidence, self.name, False, audio.duration_s, time.perf_counter() - started)


def _dither(samples: np.ndarray) -> np.ndarray:
    """One bit of noise, the same for every utterance: espeak-ng's digital silence (log of zero energy) broke the
    features, and the decoder's own dither draws on from one utterance to the next, so the same recording could be
    heard differently depending on what was heard before it."""
    noise = np.random.default_rng(1).integers(-1, 2, len(samples))
    return np.clip(samples.astype(np.int32) + noise, -32768, 32767).astype(np.int16)


def _decode(decoder, pcm: bytes, passes: int = 1) -> tuple[str, float | None, int]:
    """(words, path score as a likelihood, frames). The binding gives the score already exponentiated."""
    # Fresh features for each utterance: the decoder kept state from the one before, so a recording was heard
    # differently after a clean one than after a noisy one (8 of 60 noisy commands changed words).
    decoder.reinit_feat()
    for _ in range(passes):
        decoder.start_utt()
        decoder.process_raw(pcm, full_utt=True)
        decoder.end_utt()
    hyp = decoder.hyp()
    if hyp is None:
        return "", None, decoder.n_frames()
    return " ".join(hyp.hypstr.split()), float(hyp.score), decoder.n_frames()


def _confidence(score: float | None, loop_score: float | None, frames: int) -> float:
    ratio_per_s = fit_per_s(score, loop_score, frames)
    if ratio_per_s is None:
        return 0.0
    return min(1.0, max(0.0, 1.0 + (ratio_per_s - RATIO_AT_FULL) / RATIO_SPAN))
