"""`humanoid bench voice`: spoken commands through the recogniser and the planner.

The commands are the planner's paraphrase suite that can be said (not free text to say, not coordinates), spoken by
espeak-ng in several voices and speeds, clean and with white noise at 10 dB SNR. Reported: word error rate, how
often the plan from the transcript is right, the recogniser's real-time factor, and the latency from the end of
speech to a validated plan (decode + plan), p50 target <= 300 ms. And the robot microphone's whole path in real
time (voice-activity detection, the recogniser's process, planning): commands heard right, and the latency from
the last sound of a command reaching the microphone to its plan.
"""

from __future__ import annotations

import contextlib
import tempfile
import time
from typing import Any

import numpy as np

from harness.speech_trials import NOISY_SNR_DB, VOICES, ReplayStream, run_trials, spoken_cases, summarise, trim
from robot.events import EventBus
from robot.interface import CommandReply, Refusal
from robot.model.world import generate_world
from robot.planning.context import PlanningContext
from robot.planning.pipeline import PlannerConfig, build_pipeline
from robot.planning.planner import PlanningError
from robot.planning.world_context import WorldContext
from robot.speech.audio import RATE, Audio, add_noise
from robot.speech.devices import AudioDevice
from robot.speech.robot_voice import RobotVoice, VoiceConfig
from robot.speech.tts import synthesize_audio

WER_CLEAN_TARGET = 0.10
WER_NOISY_TARGET = 0.20
PLAN_RIGHT_TARGET = 0.90
LATENCY_P50_TARGET_MS = 300.0


ROBOT_MICROPHONE_COMMANDS = (
    "go to the charging dock",
    "pick up the red mug from the kitchen counter",
    "bring the green apple to the living room table",
    "what do you see",
    "go home",
    "find the blue bottle",
    "wait for three seconds",
    "stop",
)


def run_robot_microphone(commands: tuple[str, ...] = ROBOT_MICROPHONE_COMMANDS) -> dict[str, Any]:
    """Spoken commands with pauses between them through the robot microphone's whole path, in real time: voice
    activity detection, the recogniser's own process, the rules planner. Latency: from the last sample of speech
    reaching the microphone to the plan."""
    layout = generate_world(0)
    world = WorldContext.from_layout(layout)
    planner = build_pipeline(PlannerConfig(backend="rules"))
    pause = np.zeros(int(1.2 * RATE), np.int16)
    pieces, speech_ends = [pause], []
    for text in commands:
        speech = trim(synthesize_audio(text, "en-us", 160).samples)
        pieces += [speech, pause]
        speech_ends.append(sum(map(len, pieces)) - len(pause))
    samples = add_noise(Audio(np.concatenate(pieces)), 40.0, seed=1).samples  # a quiet room, not digital zero
    streams: list[ReplayStream] = []

    def stream(**kwargs: Any) -> ReplayStream:
        streams.append(ReplayStream(samples, **kwargs))
        return streams[-1]

    def run(text: str) -> CommandReply:
        try:
            planner.plan(text, PlanningContext(world))
            return CommandReply(True, "planned")
        except PlanningError as exc:
            return CommandReply(False, str(exc), Refusal.INVALID)

    bus = EventBus()
    with tempfile.TemporaryDirectory() as spool:
        config = VoiceConfig(spool_dir=spool, engine="pocketsphinx")  # this bench measures the grammar recogniser
        voice = RobotVoice(config, world.objects, world.places, bus.publish, run, bus.subscribe, input_stream=stream)
        voice.start(AudioDevice("input", 0, "replayed recording", RATE), AudioDevice("output", None, "", 0, "none"))
        time.sleep(len(samples) / RATE + 1.0)
        voice.stop()
    if voice.microphone is None or not streams:
        return {"commands": len(commands), "error": voice.microphone_status}
    sent_at, block = streams[0].sent_at, streams[0].block
    heard = [e for e in bus.history() if e.kind == "speech/heard"]
    latencies = []  # heard in order: the n-th utterance is the n-th command
    for event, end in zip(heard, speech_ends, strict=False):
        started = time.perf_counter()
        with contextlib.suppress(PlanningError):
            planner.plan(event.data["text"], PlanningContext(world))
        plan_s = time.perf_counter() - started
        latencies.append((event.wall_time_s - sent_at[min(len(sent_at) - 1, end // block)] + plan_s) * 1000)
    return {
        "commands": len(commands),
        "heard": len(heard),
        "heard_right": sum(e.data["text"] == c for e, c in zip(heard, commands, strict=False)),
        "ran_unasked": sum(e.data["will_run"] for e in heard),
        "end_of_speech_to_plan_ms": {
            "p50": round(float(np.percentile(latencies, 50)), 1) if latencies else None,
            "max": round(float(np.max(latencies)), 1) if latencies else None,
        },
    }


QUICK_COMMANDS = 4
QUICK_ROBOT_MICROPHONE = ("go to the charging dock", "wait for three seconds")


def run_voice(quick: bool = False) -> dict[str, Any]:
    """`quick`: one voice, a few commands, clean only, two on the robot microphone (shows the bench works)."""
    started = time.perf_counter()
    voices = VOICES[:1] if quick else VOICES
    snrs = (None,) if quick else (None, NOISY_SNR_DB)
    trials = run_trials(voices, snrs=snrs, cases=spoken_cases()[:QUICK_COMMANDS] if quick else None)
    summary = summarise(trials)
    summary["robot_microphone"] = run_robot_microphone(QUICK_ROBOT_MICROPHONE if quick else ROBOT_MICROPHONE_COMMANDS)
    clean, noisy = summary["clean"], summary.get("noisy_10db", {})
    latency = clean["end_of_speech_to_plan_ms"]["p50"]
    plan_right = min(clean["plan_right"], noisy.get("plan_right", 1.0))
    bars = {
        "wer_clean": _bar(WER_CLEAN_TARGET, clean["wer"], clean["wer"] <= WER_CLEAN_TARGET),
        "wer_noisy_10db": _bar(WER_NOISY_TARGET, noisy.get("wer"), noisy.get("wer", 1.0) <= WER_NOISY_TARGET),
        "plan_right_worst_of_clean_and_noisy": _bar(PLAN_RIGHT_TARGET, plan_right, plan_right >= PLAN_RIGHT_TARGET),
        "latency_p50_ms": _bar(LATENCY_P50_TARGET_MS, latency, latency <= LATENCY_P50_TARGET_MS),
    }
    misheard = [t.__dict__ for t in trials if not t.plan_right][:40]
    voice_labels = [f"{v}@{w}" for v, w in voices]
    wall_s = round(time.perf_counter() - started, 1)
    commands = len({t.text for t in trials})
    return {
        "suite": "voice",
        "commands": commands,
        "voices": voice_labels,
        "quick": quick,
        "wall_s": wall_s,
        **summary,
        "bars": bars,
        "misheard": misheard,
    }


def _bar(target: float, measured: float | None, met: bool) -> dict[str, Any]:
    return {"target": target, "measured": measured, "met": met}
