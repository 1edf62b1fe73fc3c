"""Spoken commands as a rig: the planner's paraphrase suite said by espeak-ng in several voices and speeds, clean
and in noise, heard by the grammar recogniser and planned (`run_trials`), word errors counted as speech research
counts them, and a recording played into the robot's microphone path in real time (`ReplayStream`).

`humanoid bench voice` and `humanoid bench speech` measure with it; the tests check recognition with it.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from harness.planner_cases import CASES, Case, context_for, plan_matches
from robot.model.world import generate_world
from robot.planning.pipeline import PlannerConfig, build_pipeline
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext, normalize
from robot.speech.audio import RATE, Audio, add_noise
from robot.speech.sphinx import PocketSphinxASR
from robot.speech.tts import synthesize_audio

VOICES = (("en-us", 160), ("en-gb", 175), ("en-us", 140), ("en-gb-x-rp", 150))
NOISY_SNR_DB = 10.0


def spoken_cases() -> tuple[Case, ...]:
    """The suite's commands a person would say to the robot as they are written."""
    return tuple(
        c
        for c in CASES
        if not any(s["action"] == "say" and s["text"] != "*" for s in c.plan) and not any(ch.isdigit() for ch in c.text)
    )


def word_errors(reference: str, hypothesis: str) -> tuple[int, int]:
    """(edit distance in words, words in the reference)."""
    ref, hyp = normalize(reference).split(), normalize(hypothesis).split()
    row = list(range(len(hyp) + 1))
    for i, r in enumerate(ref, start=1):
        previous, row[0] = row[0], i
        for j, h in enumerate(hyp, start=1):
            previous, row[j] = row[j], min(row[j] + 1, row[j - 1] + 1, previous + (r != h))
    return row[len(hyp)], len(ref)


@dataclass
class Trial:
    text: str
    voice: str
    wpm: int
    snr_db: float | None
    heard: str
    confidence: float
    in_grammar: bool
    errors: int
    words: int
    plan_right: bool
    decode_ms: float
    plan_ms: float
    audio_s: float


def run_trials(
    voices: tuple[tuple[str, int], ...] = VOICES,
    snrs: tuple[float | None, ...] = (None, NOISY_SNR_DB),
    cases: tuple[Case, ...] | None = None,
) -> list[Trial]:
    layout = generate_world(0)
    world = WorldContext.from_layout(layout)
    asr = PocketSphinxASR(world.objects, world.places)
    planner = build_pipeline(PlannerConfig(backend="rules"))
    trials = []
    for index, case in enumerate(cases or spoken_cases()):
        for voice, wpm in voices:
            clean = synthesize_audio(case.text, voice, wpm)
            for snr in snrs:
                audio: Audio = clean if snr is None else add_noise(clean, snr, seed=index)
                transcript = asr.transcribe(audio)
                started = time.perf_counter()
                try:
                    result = planner.plan(transcript.text, context_for(case, layout)) if transcript.text else None
                except PlanningError:
                    result = None
                plan_ms = (time.perf_counter() - started) * 1000
                errors, words = word_errors(case.text, transcript.text)
                right = result is not None and plan_matches(case.plan, result.plan.to_seed_list())
                trials.append(
                    Trial(
                        case.text,
                        voice,
                        wpm,
                        snr,
                        transcript.text,
                        round(transcript.confidence, 3),
                        transcript.in_grammar,
                        errors,
                        words,
                        right,
                        transcript.decode_s * 1000,
                        plan_ms,
                        audio.duration_s,
                    )
                )
    return trials


def summarise(trials: list[Trial]) -> dict[str, Any]:
    def group(selected: list[Trial]) -> dict[str, Any]:
        errors = sum(t.errors for t in selected)
        words = sum(t.words for t in selected)
        latency = np.asarray([t.decode_ms + t.plan_ms for t in selected])
        rtf = np.asarray([t.decode_ms / 1000 / t.audio_s for t in selected])
        return {
            "utterances": len(selected),
            "wer": round(errors / words, 4) if words else 0.0,
            "plan_right": round(sum(t.plan_right for t in selected) / len(selected), 4),
            "in_grammar": round(sum(t.in_grammar for t in selected) / len(selected), 4),
            "end_of_speech_to_plan_ms": {
                "p50": round(float(np.percentile(latency, 50)), 1),
                "p99": round(float(np.percentile(latency, 99)), 1),
            },
            "asr_real_time_factor": {"mean": round(float(rtf.mean()), 4), "max": round(float(rtf.max()), 4)},
        }

    clean = [t for t in trials if t.snr_db is None]
    noisy = [t for t in trials if t.snr_db is not None]
    result: dict[str, Any] = {"clean": group(clean)} if clean else {}
    if noisy:
        result["noisy_10db"] = group(noisy)
    right = [t.confidence for t in trials if t.plan_right]
    wrong = [t.confidence for t in trials if not t.plan_right]
    result["confidence"] = {
        "right_plans_mean": round(float(np.mean(right)), 3) if right else None,
        "wrong_plans_mean": round(float(np.mean(wrong)), 3) if wrong else None,
        "wrong_plans_at_or_above_0.6": sum(c >= 0.6 for c in wrong),
    }
    return result


class ReplayStream:
    """An input device that plays a recording in real time (as `sounddevice.InputStream` calls back), noting when
    each block went out."""

    def __init__(
        self,
        samples: np.ndarray,
        samplerate: int,
        channels: int,
        dtype: str,
        device: int,
        blocksize: int,
        callback: Any,
    ) -> None:
        self.samples, self.block, self.callback = samples, blocksize, callback
        self.sent_at: list[float] = []  # wall-clock time each block was delivered
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()

    def close(self) -> None:
        pass

    def _run(self) -> None:
        started = time.monotonic()
        for start in range(0, len(self.samples), self.block):
            if self._stop.is_set():
                return
            time.sleep(max(0.0, started + start / RATE - time.monotonic()))
            self.callback(self.samples[start : start + self.block].reshape(-1, 1), self.block, None, None)
            self.sent_at.append(time.time())


def trim(samples: np.ndarray) -> np.ndarray:
    """espeak-ng's leading and trailing digital silence off: "end of speech" is the last sound."""
    loud = np.flatnonzero(np.abs(samples) > 200)
    return samples[loud[0] : loud[-1] + 1] if len(loud) else samples
