"""`humanoid bench speech`: the spoken figures of issue 34, per set (dev, the one tuned on; heldout, never tuned on)
and per recogniser.

Every sentence of a set is spoken by espeak-ng in each of the set's voices, with 0.4 s before and 0.3 s after it
(as a push-to-talk recording has), clean (a quiet room: white noise 40 dB below the speech) and with brown noise at
10 dB SNR. Reported per engine: word error rate (fillers such as "um" left out of both sides, numbers as words),
how often the plan from the transcript is right (with the planner this build has), how sure the recogniser was
when it was right and when it was wrong, and the time from the end of speech to a validated plan. Per set: the
spoken stop (stop utterances heard, false stops on ordinary commands, those containing "stop" included). And the
robot microphone's whole path in real time: the time from the end of a spoken stop to the e-stop latching.
"""

from __future__ import annotations

import tempfile
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from harness.planner_cases import Case, context_for, plan_matches
from harness.speech_trials import ReplayStream, trim, word_errors
from harness.spoken_cases import ROOM_SNR_DB, SETS, SpokenSet, utterance
from robot.events import EventBus
from robot.interface import CommandReply
from robot.model.world import generate_world
from robot.planning.context import PlanningContext
from robot.planning.heard import first_readable
from robot.planning.pipeline import PlannerConfig, PlanningPipeline, build_pipeline
from robot.planning.planner import ClarificationNeeded, PlanningError
from robot.planning.world_context import WorldContext, normalize
from robot.speech.asr import AUTO_RUN_CONFIDENCE, SpeechRecognizer
from robot.speech.audio import RATE, Audio, add_noise
from robot.speech.devices import AudioDevice
from robot.speech.engines import build_recognizer
from robot.speech.robot_voice import RobotVoice, VoiceConfig
from robot.speech.stop_word import StopSpotter, transcript_is_stop
from robot.speech.tts import synthesize_audio
from robot.speech.world_reading import WorldReadRecognizer

NOISY_SNR_DB = 10.0
BARS = {
    "plan_right_clean": 0.90,
    "plan_right_noisy": 0.80,
    "wer_clean": 0.12,
    "wer_noisy": 0.18,
    "stop_heard": 0.98,
    "false_stops_per_30": 1.0,
    "end_of_speech_to_plan_p50_ms": 800.0,
    "robot_microphone_stop_p50_ms": 300.0,
}
FILLERS = {"um", "uh", "er", "erm", "hmm", "ah", "oh"}
NUMBERS = {
    "1": "one",
    "2": "two",
    "3": "three",
    "4": "four",
    "5": "five",
    "6": "six",
    "7": "seven",
    "8": "eight",
    "9": "nine",
    "10": "ten",
}


def wer_words(text: str) -> str:
    """The words as word error rate counts them: no fillers, "ok" as "okay", numbers as words, no hyphens."""
    words = normalize(text.replace("-", " ")).split()
    words = [NUMBERS.get(w, "okay" if w == "ok" else w) for w in words]
    return " ".join(w for w in words if w not in FILLERS)


@dataclass
class Heard:
    set: str
    kind: str  # command, with_stop, stop
    text: str
    voice: str
    snr_db: float | None
    engine: str
    heard: str
    confidence: float
    errors: int
    words: int
    exact: bool  # the transcript's words are the sentence's (as word error rate counts them)
    plan_right: bool | None  # None: a stop utterance (judged by the stop figures); out of the world: no plan
    planned: bool  # the planner made a plan of the transcript (or of one of the recogniser's other wordings)
    decode_ms: float
    plan_ms: float
    spot_ms: float
    spotted_stop: bool
    transcript_stop: bool
    asked: bool = False  # the plan is of another wording the recogniser heard: it waits for the operator's yes
    heard_again: bool = False  # a second model heard it again (the first was not sure)
    # the engine's likeliest wording's errors, when the transcript is another (read against the world)
    first_errors: int | None = None


def _plan(
    planner, text: str, case: Case | None, layout, alternatives: tuple[str, ...] = (), read_in_world: bool = False
) -> tuple[bool | None, bool, float, bool]:
    """(plan right, a plan was made, planning ms, the plan is of one of the recogniser's other wordings: the robot
    asks "did you mean ...?" before running it, or the page waits for Send when the transcript was read against the
    world). With no case (a request out of the world), right is no plan."""
    started = time.perf_counter()
    context = context_for(case, layout) if case is not None else PlanningContext(WorldContext.from_layout(layout))
    result, asked = None, read_in_world
    try:
        result = planner.plan(text, context) if text else None
    except ClarificationNeeded:
        pass
    except PlanningError:
        heard = first_readable(planner, alternatives, context) if text else None
        if heard is not None:
            result, asked = heard[1], True
    elapsed = (time.perf_counter() - started) * 1000
    if case is None:
        return result is None, result is not None, elapsed, asked
    if result is None:
        return False, False, elapsed, False
    return plan_matches(case.plan, result.plan.to_seed_list()), True, elapsed, asked


def run_set(
    spoken: SpokenSet,
    engines: tuple[str, ...],
    snrs: tuple[float | None, ...] = (None, NOISY_SNR_DB),
    whisper_threads: int = 2,
    whisper_model: str = "",
    whisper_second_model: str = "auto",
    planner: PlanningPipeline | None = None,
) -> list[Heard]:
    """Every utterance of `spoken`, heard by each engine and planned by `planner` (the rules planner unless told)."""
    layout = generate_world(0)
    world = WorldContext.from_layout(layout)
    planner = planner or build_pipeline(PlannerConfig(backend="rules"))
    recognizers: dict[str, SpeechRecognizer] = {}
    for engine in engines:
        if engine == "whisper":  # built here with the bench's threads and models (not the settings')
            from robot.speech.whisper import WhisperASR

            whisper = WhisperASR(
                whisper_model, world.objects, world.places, threads=whisper_threads, second_model=whisper_second_model
            )
            recognizers[engine] = WorldReadRecognizer(whisper, world)
        else:
            recognizers[engine] = build_recognizer(engine, world.objects, world.places, world=world)
    spotter = StopSpotter(world.objects, world.places)
    items: list[tuple[str, str, Case | None]] = [("command", c.text, c) for c in spoken.commands]
    items += [("with_stop", c.text, c) for c in spoken.with_stop] + [("stop", t, None) for t in spoken.stops]
    items += [("out_of_world", t, None) for t in spoken.out_of_world]
    results = []
    seed = 0
    for kind, text, case in items:
        for voice in spoken.voices:
            for snr in snrs:
                seed += 1
                audio = utterance(text, voice, snr, seed)
                verdict = spotter.spot(audio)
                for engine, recognizer in recognizers.items():
                    transcript = recognizer.transcribe(audio)
                    if kind == "stop":
                        right, planned, plan_ms, asked = None, False, 0.0, False
                    else:
                        right, planned, plan_ms, asked = _plan(
                            planner,
                            transcript.text,
                            case,
                            layout,
                            transcript.alternatives,
                            bool(transcript.first_heard),
                        )
                    errors, words = word_errors(wer_words(text), wer_words(transcript.text))
                    first = transcript.first_heard or transcript.text
                    first_errors = word_errors(wer_words(text), wer_words(first))[0]
                    results.append(
                        Heard(
                            spoken.name,
                            kind,
                            text,
                            voice.label(),
                            snr,
                            engine,
                            transcript.text,
                            round(transcript.confidence, 3),
                            errors,
                            words,
                            errors == 0,
                            right,
                            planned,
                            transcript.decode_s * 1000,
                            plan_ms,
                            verdict.decode_s * 1000,
                            verdict.stop,
                            transcript_is_stop(transcript),
                            asked,
                            transcript.heard_again,
                            first_errors,
                        )
                    )
    return results


def _rate(selected: list[bool]) -> float | None:
    return round(sum(selected) / len(selected), 4) if selected else None


def summarise(results: list[Heard]) -> dict[str, Any]:
    """Per set and engine: clean and noisy figures, the spoken stop, and how sure the recogniser was."""
    out: dict[str, Any] = {}
    for set_name in dict.fromkeys(r.set for r in results):
        per_set: dict[str, Any] = {}
        for engine in dict.fromkeys(r.engine for r in results if r.set == set_name):
            mine = [r for r in results if r.set == set_name and r.engine == engine]
            per_set[engine] = {
                "clean": _group([r for r in mine if r.snr_db is None]),
                "noisy_10db_brown": _group([r for r in mine if r.snr_db is not None]),
                "stop": _stops(mine),
                "out_of_world": _out_of_world([r for r in mine if r.kind == "out_of_world"]),
                "confidence": _confidence(mine),
            }
        out[set_name] = per_set
    return out


def _group(selected: list[Heard]) -> dict[str, Any]:
    commands = [r for r in selected if r.kind in COMMAND_KINDS]
    judged = [r for r in commands if r.plan_right is not None]
    errors = sum(r.errors for r in commands)
    words = sum(r.words for r in commands)
    latency = np.asarray([r.decode_ms + r.plan_ms for r in commands]) if commands else np.zeros(1)
    with_spot = latency + np.asarray([r.spot_ms for r in commands]) if commands else latency
    return {
        "utterances": len(commands),
        "wer": round(errors / words, 4) if words else None,
        "wer_everyday": _wer([r for r in commands if r.kind == "command"]),
        # of the engine's likeliest wordings, before the transcript is read against the world
        "wer_first_wording": round(
            sum(r.errors if r.first_errors is None else r.first_errors for r in commands) / words, 4
        )
        if words
        else None,
        "plan_right": _rate([bool(r.plan_right) for r in judged]),
        # of the right plans, those of another wording the recogniser heard (the robot asks before running them)
        "plan_right_asked_first": _rate([bool(r.plan_right) and r.asked for r in judged]),
        "plan_right_as_heard": _rate([bool(r.plan_right) and not r.asked for r in judged]),
        "transcript_exact": _rate([r.exact for r in commands]),
        # heard again by the second model, because the first was not sure (their decoding time is in the latency)
        "heard_again": _rate([r.heard_again for r in commands]),
        "decode_ms_p50": round(float(np.percentile([r.decode_ms for r in commands] or [0], 50)), 1),
        "end_of_speech_to_plan_ms": {
            "p50": round(float(np.percentile(latency, 50)), 1),
            "p90": round(float(np.percentile(latency, 90)), 1),
        },
        "with_stop_check_ms": {"p50": round(float(np.percentile(with_spot, 50)), 1)},
    }


def _out_of_world(selected: list[Heard]) -> dict[str, Any]:
    """Requests for what is not in the world or not an ability: refused, asked about (a plan of another wording,
    waiting for the operator), or planned as heard (wrong: the page shows it for Send); and of those planned as heard,
    the ones sure enough to run unasked when the operator lets sure transcripts run (the worst case: acted on)."""
    return {
        "utterances": len(selected),
        "refused": _rate([not r.planned for r in selected]),
        "asked_about": _rate([r.planned and r.asked for r in selected]),
        "planned_as_heard": _rate([r.planned and not r.asked for r in selected]),
        "would_run_unasked": _rate(
            [r.planned and not r.asked and r.confidence >= AUTO_RUN_CONFIDENCE for r in selected]
        ),
        "planned_heard": [
            f"{r.text} ({r.voice}, {_condition(r)}): {r.heard!r}, confidence {r.confidence:.2f}"
            + (", asked first" if r.asked else "")
            for r in selected
            if r.planned
        ],
    }


def _wer(selected: list[Heard]) -> float | None:
    words = sum(r.words for r in selected)
    return round(sum(r.errors for r in selected) / words, 4) if words else None


def _stops(mine: list[Heard]) -> dict[str, Any]:
    stops = [r for r in mine if r.kind == "stop"]
    ordinary = [r for r in mine if r.kind != "stop"]
    heard = [r.spotted_stop or r.transcript_stop for r in stops]
    false = [r.spotted_stop or r.transcript_stop for r in ordinary]
    return {
        "stop_utterances": len(stops),
        "heard": _rate(heard),
        "heard_by_spotter": _rate([r.spotted_stop for r in stops]),
        "heard_clean": _rate([r.spotted_stop or r.transcript_stop for r in stops if r.snr_db is None]),
        "heard_noisy": _rate([r.spotted_stop or r.transcript_stop for r in stops if r.snr_db is not None]),
        "ordinary_commands": len(ordinary),
        "false_stops": sum(false),
        "false_stops_per_30": round(30 * sum(false) / len(ordinary), 2) if ordinary else None,
        "false_stops_on_commands_with_stop": sum(
            r.spotted_stop or r.transcript_stop for r in ordinary if r.kind == "with_stop"
        ),
        "missed": sorted(
            {f"{r.text} ({r.voice}, {_condition(r)})" for r in stops if not (r.spotted_stop or r.transcript_stop)}
        ),
        # which stage took an ordinary utterance for a stop: the spotter (with the grammar) or the transcript's words
        "false_stops_heard": [
            f"{r.text} ({r.voice}, {_condition(r)}): {'spotter' if r.spotted_stop else 'transcript'}, {r.heard!r}"
            for r in ordinary
            if r.spotted_stop or r.transcript_stop
        ],
    }


def _condition(r: Heard) -> str:
    return "clean" if r.snr_db is None else "noisy"


def _confidence(mine: list[Heard]) -> dict[str, Any]:
    """Whether "run when sure" can be trusted: of the transcripts sure enough to run unasked, how many were right."""
    commands = [r for r in mine if r.kind in COMMAND_KINDS and r.plan_right is not None]
    sure = [r for r in commands if r.confidence >= AUTO_RUN_CONFIDENCE and r.planned and not r.asked]
    return {
        "threshold": AUTO_RUN_CONFIDENCE,
        "exact_mean": _mean([r.confidence for r in commands if r.exact]),
        "wrong_mean": _mean([r.confidence for r in commands if not r.exact]),
        "would_run_unasked": len(sure),
        "of_those_transcript_exact": _rate([r.exact for r in sure]),
        "of_those_plan_right": _rate([bool(r.plan_right) for r in sure]),
    }


def _mean(values: list[float]) -> float | None:
    return round(float(np.mean(values)), 3) if values else None


ROBOT_STOPS = ("stop", "halt", "freeze", "robot stop", "emergency stop", "stop right now")


def run_robot_microphone_stops(phrases: tuple[str, ...] = ROBOT_STOPS, engine: str = "auto") -> dict[str, Any]:
    """Stop phrases with pauses between them through the robot microphone's whole path in real time (voice-activity
    detection, the spotter's process, the recogniser's beside it): the time from the last sound of each phrase
    reaching the microphone to the e-stop being latched."""
    layout = generate_world(0)
    world = WorldContext.from_layout(layout)
    pause = np.zeros(int(1.5 * RATE), np.int16)
    pieces, speech_ends = [pause], []
    for text in phrases:
        pieces += [trim(synthesize_audio(text, "en-us", 160).samples), pause]
        speech_ends.append(sum(map(len, pieces)) - len(pause))
    samples = add_noise(Audio(np.concatenate(pieces)), ROOM_SNR_DB, seed=1).samples
    streams: list[ReplayStream] = []
    latched: list[float] = []
    lock = threading.Lock()

    def stream(**kwargs: Any) -> ReplayStream:
        streams.append(ReplayStream(samples, **kwargs))
        return streams[-1]

    def estop() -> CommandReply:
        with lock:
            latched.append(time.time())
        return CommandReply(True, "e-stop latched")

    bus = EventBus()
    with tempfile.TemporaryDirectory() as spool:
        voice = RobotVoice(
            VoiceConfig(spool_dir=spool, engine=engine),
            world.objects,
            world.places,
            bus.publish,
            lambda text: CommandReply(True, "planned"),
            bus.subscribe,
            input_stream=stream,
            estop=estop,
        )
        voice.start(AudioDevice("input", 0, "replayed recording", RATE), AudioDevice("output", None, "", 0, "none"))
        time.sleep(len(samples) / RATE + 2.0)
        voice.stop()
    if not streams:
        return {"phrases": len(phrases), "error": voice.microphone_status}
    sent_at, block = streams[0].sent_at, streams[0].block
    ends = [sent_at[min(len(sent_at) - 1, end // block)] for end in speech_ends]
    latencies, missed = [], []
    for i, (text, end) in enumerate(zip(phrases, ends, strict=True)):
        following = ends[i + 1] if i + 1 < len(ends) else float("inf")
        mine = [at for at in latched if end <= at < following]  # a latch belongs to the phrase before it
        if mine:
            latencies.append((mine[0] - end) * 1000)
        else:
            missed.append(text)
    return {
        "phrases": len(phrases),
        "latched": len(phrases) - len(missed),
        "missed": missed,
        "spotter_latches": sum(e.data.get("stage") == "spotter" for e in bus.history() if e.kind == "speech/stop"),
        "end_of_word_to_estop_ms": {
            "p50": round(float(np.percentile(latencies, 50)), 1) if latencies else None,
            "max": round(float(np.max(latencies)), 1) if latencies else None,
            "all": [round(x, 1) for x in latencies],
        },
    }


QUICK_ROBOT_STOPS = ("stop", "freeze")
MISHEARD_SHOWN = 40  # per set
COMMAND_KINDS = ("command", "with_stop")  # utterances with a plan to give


def run_speech(
    sets: tuple[str, ...] = tuple(SETS),
    engines: tuple[str, ...] = ("whisper", "pocketsphinx"),
    robot_microphone: bool = True,
    quick: bool = False,
    whisper_model: str = "",
    whisper_second_model: str = "auto",
) -> dict[str, Any]:
    """`quick`: per set one voice, one command, one stop and one command with a stop in it, clean only, and two
    stops on the robot microphone (shows the bench works; its figures mean little)."""
    started = time.perf_counter()
    chosen = [few(SETS[name]) if quick else SETS[name] for name in sets]
    snrs = (None,) if quick else (None, NOISY_SNR_DB)
    results = [r for spoken in chosen for r in run_set(spoken, engines, snrs, 2, whisper_model, whisper_second_model)]
    summary = summarise(results)
    result: dict[str, Any] = {"suite": "speech", "planner": "rules (this build's)", "quick": quick, "sets": summary}
    if "whisper" in engines:
        from robot.speech.whisper import model_dir
        from robot.speech.whisper_models import second_model_dir

        result["whisper_model"] = str(model_dir(whisper_model))
        second = second_model_dir(whisper_second_model)
        result["whisper_second_model"] = str(second) if second is not None else None
    if robot_microphone:
        if quick:
            result["robot_microphone_stop"] = run_robot_microphone_stops(QUICK_ROBOT_STOPS, engine="pocketsphinx")
        else:
            result["robot_microphone_stop"] = run_robot_microphone_stops()
    result["bars"] = speech_bars(summary, result.get("robot_microphone_stop"))
    result["misheard"] = [
        r.__dict__
        for name in sets
        for r in [r for r in results if r.set == name and r.kind in COMMAND_KINDS and r.plan_right is False][
            :MISHEARD_SHOWN
        ]
    ]
    result["wall_s"] = round(time.perf_counter() - started, 1)
    return result


def few(spoken: SpokenSet) -> SpokenSet:
    """One voice, and one sentence of each kind."""
    return SpokenSet(
        spoken.name,
        spoken.voices[:1],
        spoken.commands[:1],
        spoken.stops[:1],
        spoken.with_stop[:1],
        spoken.out_of_world[:1],
    )


def speech_bars(summary: dict[str, Any], robot: dict[str, Any] | None) -> dict[str, Any]:
    bars: dict[str, Any] = {}
    for set_name, engines in summary.items():
        for engine, figures in engines.items():
            clean, noisy, stop = figures["clean"], figures["noisy_10db_brown"], figures["stop"]
            measured = {
                "plan_right_clean": clean["plan_right"],
                "plan_right_noisy": noisy["plan_right"],
                "wer_clean": clean["wer"],
                "wer_noisy": noisy["wer"],
                "stop_heard": stop["heard"],
                "false_stops_per_30": stop["false_stops_per_30"],
                "end_of_speech_to_plan_p50_ms": clean["end_of_speech_to_plan_ms"]["p50"],
            }
            for name, value in measured.items():
                lower_is_better = name.startswith(("wer", "false", "end_of"))
                target = BARS[name]
                met = value is not None and (value <= target if lower_is_better else value >= target)
                bars[f"{set_name}/{engine}/{name}"] = {"target": target, "measured": value, "met": met}
    if robot is not None:
        p50 = robot["end_of_word_to_estop_ms"]["p50"]
        target = BARS["robot_microphone_stop_p50_ms"]
        bars["robot_microphone_stop_p50_ms"] = {
            "target": target,
            "measured": p50,
            "met": p50 is not None and p50 <= target,
        }
    return bars
