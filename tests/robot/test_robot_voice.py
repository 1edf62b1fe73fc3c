"""The robot's own microphone and speaker: utterances cut from a stream, heard, run when sure, kept; the robot's
`say` steps played aloud without it hearing itself; and a plain word when there is no device."""

from __future__ import annotations

import os
import signal
import threading
import time
import wave
from pathlib import Path

import numpy as np
import pytest

from robot.events import EventBus
from robot.interface import CommandReply, Level, RunCommand
from robot.model.world import generate_world
from robot.planning.world_context import WorldContext
from robot.speech import devices
from robot.speech.audio import Audio, add_noise
from robot.speech.devices import AudioDevice, find_device
from robot.speech.recognizer_process import RecognizerGone, RecognizerProcess
from robot.speech.robot_voice import RobotVoice, VoiceConfig
from robot.speech.tts import synthesize_audio
from robot.speech.vad import UtteranceDetector

pytestmark = pytest.mark.skipif(not __import__("shutil").which("espeak-ng"), reason="needs espeak-ng")
MIC = AudioDevice("input", 3, "test microphone", 16000)
SPEAKER = AudioDevice("output", 4, "test speaker", 16000)


def _speech(text: str) -> np.ndarray:
    return synthesize_audio(text, "en-us", 150).samples


def _stream(*parts: np.ndarray | float) -> np.ndarray:
    """Speech and pauses (seconds of silence), with a little room noise so the silence is not digital zero."""
    pieces = [np.zeros(int(p * 16000), np.int16) if isinstance(p, float) else p for p in parts]
    return add_noise(Audio(np.concatenate(pieces)), 35.0, seed=3).samples


@pytest.mark.parametrize("snr_db", [None, 10.0])
def test_each_utterance_is_cut_where_the_speech_is(snr_db) -> None:
    first, second = _speech("go to the charging dock"), _speech("pick up the red mug")
    samples = _stream(1.0, first, 1.5, second, 1.0)
    if snr_db is not None:
        samples = add_noise(Audio(samples), snr_db, seed=5).samples
    detector = UtteranceDetector()
    utterances = [u for block in np.array_split(samples, 97) for u in detector.feed(block)]  # blocks of ~60 ms
    assert len(utterances) == 2
    for utterance, speech in zip(utterances, (first, second), strict=True):
        # all of the words, and not much of the pauses around them (espeak's own output ends in ~0.3 s of quiet)
        assert len(speech) / 16000 - 0.5 <= utterance.duration_s <= len(speech) / 16000 + 0.7


def test_silence_and_steady_noise_are_no_utterance() -> None:
    speech = _speech("go to the charging dock").astype(np.float64)
    power = np.mean(speech[np.abs(speech) > 0.02 * np.abs(speech).max()] ** 2)
    noise = np.random.default_rng(2).normal(0.0, np.sqrt(power / 10), 16000 * 4)  # as loud as at 10 dB SNR
    samples = np.concatenate([_stream(3.0), np.round(noise).astype(np.int16)])
    detector = UtteranceDetector()
    assert [u for block in np.array_split(samples, 50) for u in detector.feed(block)] == []


def test_no_device_is_said_plainly(monkeypatch) -> None:
    sd = pytest.importorskip("sounddevice")
    monkeypatch.setattr(sd, "query_devices", lambda *a, **k: [] if not a and not k else {})
    missing = find_device("input", "auto")
    assert not missing.available and missing.problem == "the system has no audio input device"
    assert missing.describe() == "no robot microphone: the system has no audio input device"
    off = find_device("output", "off")
    assert not off.available and off.describe() == "no robot speaker: off by setting"


def test_a_device_named_that_does_not_exist_lists_the_ones_that_do(monkeypatch) -> None:
    sd = pytest.importorskip("sounddevice")
    listed = [{"name": "USB mic", "index": 0, "max_input_channels": 1, "max_output_channels": 0}]

    def query(device=None, kind=None):
        if device is None and kind is None:
            return listed
        raise ValueError(f"No input device matching {device!r}")

    monkeypatch.setattr(sd, "query_devices", query)
    missing = devices.find_device("input", "ReSpeaker")
    assert not missing.available and "no 'ReSpeaker' input device" in missing.problem and "'USB mic'" in missing.problem


class FakeInputStream:
    """Plays `samples` into the callback in 30 ms blocks, at twice real time, as PortAudio would (then silence)."""

    samples = np.zeros(0, np.int16)

    def __init__(self, samplerate, channels, dtype, device, blocksize, callback) -> None:
        assert (samplerate, channels, dtype, device) == (16000, 1, "int16", MIC.index)
        self._callback, self._block = callback, blocksize
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
        data = np.concatenate([type(self).samples, np.zeros(16000 * 60, np.int16)])
        for start in range(0, len(data), self._block):
            if self._stop.is_set():
                return
            self._callback(data[start : start + self._block].reshape(-1, 1), self._block, None, None)
            time.sleep(self._block / 16000 / 2)


class FakeOutputStream:
    written: list[np.ndarray] = []

    def __init__(self, samplerate, channels, dtype, device) -> None:
        assert (samplerate, channels, dtype, device) == (16000, 1, "int16", SPEAKER.index)

    def __enter__(self) -> FakeOutputStream:
        return self

    def __exit__(self, *exc) -> None:
        pass

    def write(self, samples: np.ndarray) -> None:
        type(self).written.append(samples.copy())
        time.sleep(len(samples) / 16000 / 2)  # playing takes (half) the sentence's time


@pytest.fixture(scope="module")
def world() -> WorldContext:
    return WorldContext.from_layout(generate_world(0))


@pytest.fixture
def voice_rig(world, tmp_path):
    """A RobotVoice on fake devices, its real recogniser process, an event bus and a command log."""
    bus, commands, voices = EventBus(), [], []

    def make(samples: np.ndarray, auto_run: bool = True, speaker: bool = False, spoken_stop: bool = True) -> RobotVoice:
        FakeInputStream.samples = samples
        FakeOutputStream.written = []

        def run(command: RunCommand) -> CommandReply:
            commands.append(command.text)
            return CommandReply(True, "planned", command_id=len(commands))

        def estop() -> CommandReply:
            commands.append("E-STOP")
            return CommandReply(True, "e-stop latched")

        # the grammar recogniser: its transcripts are the commands' own words (whisper's are tested apart)
        config = VoiceConfig(
            engine="pocketsphinx", auto_run=auto_run, spoken_stop=spoken_stop, spool_dir=str(tmp_path / "incoming")
        )
        voice = RobotVoice(
            config,
            world.objects,
            world.places,
            bus.publish,
            run,
            bus.subscribe,
            FakeInputStream,
            FakeOutputStream,
            estop=estop,
        )
        voice.start(MIC, SPEAKER if speaker else AudioDevice("output", None, "", 0, "off by setting"))
        voices.append(voice)
        return voice

    yield bus, commands, make
    for voice in voices:
        voice.stop()


def _events(bus: EventBus, kind: str, count: int, timeout_s: float = 30.0) -> list:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        found = [e for e in bus._history if e.kind == kind]
        if len(found) >= count:
            return found
        time.sleep(0.05)
    raise AssertionError(f"{count} {kind} events not seen in {timeout_s} s: {[e.kind for e in bus._history]}")


def test_a_command_heard_by_the_robot_runs_and_its_recording_is_kept(voice_rig) -> None:
    bus, commands, make = voice_rig
    make(_stream(0.8, _speech("go to the charging dock"), 1.0))
    started = _events(bus, "speech/microphone", 1)[0]
    assert started.level == Level.OK and "test microphone" in started.message
    assert "a spoken stop latches the e-stop" in started.message and started.data["spoken_stop"]
    heard = _events(bus, "speech/heard", 1)[0].data
    assert heard["text"] == "go to the charging dock" and heard["in_grammar"] and heard["will_run"]
    assert heard["source"] == "robot-mic" and heard["confidence"] >= 0.7
    ran = _events(bus, "speech/command", 1)[0].data
    assert commands == ["go to the charging dock"] and ran["accepted"] and ran["command_id"] == 1
    with wave.open(heard["audio_path"]) as recording:  # the utterance itself, for the session to keep
        assert recording.getframerate() == 16000 and 1.2 < recording.getnframes() / 16000 < 3.0


def test_speech_that_is_no_sure_command_waits_for_the_operator(voice_rig) -> None:
    bus, commands, make = voice_rig
    make(
        _stream(0.8, _speech("the weather is lovely this afternoon"), 1.0, _speech("go to the charging dock"), 1.0),
        auto_run=False,
    )
    heard = [e.data for e in _events(bus, "speech/heard", 2)]
    assert [h["will_run"] for h in heard] == [False, False]  # not sure, and (second) not allowed to run unasked
    assert not heard[0]["auto_run"] and heard[1]["auto_run"] and heard[1]["text"] == "go to the charging dock"
    time.sleep(0.3)
    assert commands == [] and not [e for e in bus._history if e.kind == "speech/command"]


def test_the_robot_speaks_its_say_steps_and_does_not_obey_its_own_voice(voice_rig) -> None:
    bus, commands, make = voice_rig
    # the room hears the robot's own sentence while it plays (an echo of a command)
    voice = make(_stream(1.5, _speech("go to the charging dock"), 2.0), speaker=True)
    assert "test speaker" in _events(bus, "speech/speaker", 1)[0].message
    bus.publish("speech/say", "go to the charging dock", text="go to the charging dock")
    deadline = time.monotonic() + 10
    while not FakeOutputStream.written and time.monotonic() < deadline:
        time.sleep(0.02)
    played = np.concatenate(FakeOutputStream.written)
    assert 1.2 < len(played) / 16000 < 3.0 and np.abs(played).max() > 3000  # the sentence, aloud
    time.sleep(3.0)
    assert voice.speaker.spoken == 1
    assert commands == [] and not [e for e in bus._history if e.kind == "speech/heard"]


def test_a_spoken_stop_latches_the_robots_estop_and_stop_inside_a_command_does_not(voice_rig) -> None:
    bus, commands, make = voice_rig
    make(
        _stream(
            0.8,
            _speech("go to the dock and stop there"),
            1.2,
            _speech("stop"),
            1.2,
            _speech("go to the charging dock"),
            1.0,
        )
    )
    heard = [e.data for e in _events(bus, "speech/heard", 3)]
    assert [h["stop"] for h in heard] == [False, True, False], heard
    stops = [e.data for e in bus.history() if e.kind == "speech/stop"]
    assert len(stops) == 1 and stops[0]["stage"] == "spotter" and stops[0]["accepted"], stops
    # latched once, for the stop alone, before the command heard after it
    assert commands == ["E-STOP", "go to the charging dock"], commands


def test_with_the_spoken_stop_off_stop_is_an_ordinary_command(voice_rig) -> None:
    bus, commands, make = voice_rig
    voice = make(_stream(0.8, _speech("stop"), 1.0), spoken_stop=False)
    heard = _events(bus, "speech/heard", 1)[0].data
    assert heard["text"].startswith("stop") and heard["stop"] is False and not voice.spoken_stop
    assert "E-STOP" not in commands and not [e for e in bus.history() if e.kind == "speech/stop"]
    assert "spoken stop" not in _events(bus, "speech/microphone", 1)[0].message


def test_the_recogniser_process_answers_like_the_engine_and_reports_a_bad_engine(world) -> None:
    process = RecognizerProcess("pocketsphinx", world.objects, world.places)
    try:
        transcript = process.transcribe(synthesize_audio("bring me the green apple", "en-us", 150))
        assert transcript.text == "bring me the green apple" and transcript.in_grammar
        os.kill(process.pid, signal.SIGKILL)  # killed (or crashed) before or while it decodes: gone, not a bad answer
        with pytest.raises(RecognizerGone, match=r"exited with code -9|has gone"):
            process.transcribe(synthesize_audio("bring me the green apple", "en-us", 150))
    finally:
        process.close()
    with pytest.raises(Exception, match="unknown speech engine 'klingon'"):
        RecognizerProcess("klingon", world.objects, world.places)


def test_a_worker_without_devices_says_so_and_keeps_working(make_worker) -> None:
    worker = make_worker(realtime=False, voice=VoiceConfig(microphone="off", speaker="nonexistent-speaker-xyz"))
    events = {e.kind: e for e in worker.recent_events()}
    assert events["speech/microphone"].level == Level.OK and "off by setting" in events["speech/microphone"].message
    speaker = events["speech/speaker"]
    assert speaker.level == Level.WARN and "the page speaks for the robot" in speaker.message
    description = worker.describe()
    assert description.microphone == "no robot microphone: off by setting"
    assert description.speaker.startswith("no robot speaker: ")


def test_spooled_recordings_move_into_the_session_folder(tmp_path: Path) -> None:
    from app.sessions.audio_store import keep_recording, recording_file

    spooled = tmp_path / "incoming" / "heard-1.wav"
    spooled.parent.mkdir()
    spooled.write_bytes(Audio(np.zeros(1600, np.int16)).wav_bytes())
    relative = keep_recording(tmp_path / "audio", 7, spooled)
    assert relative is not None and relative.startswith("7/") and not spooled.exists()
    assert recording_file(tmp_path / "audio", relative) is not None
    assert keep_recording(tmp_path / "audio", 7, spooled) is None  # gone: nothing to keep, no error


def test_a_recogniser_that_dies_is_restarted_and_the_robot_listens_on(voice_rig) -> None:
    bus, commands, make = voice_rig
    voice = make(_stream(1.0, _speech("hello there"), 1.5, _speech("go to the charging dock"), 1.0))
    voice._recognizer._process.kill()  # as if the decoder crashed: the first utterance is lost with it
    failed = _events(bus, "speech/microphone", 2)[1]
    assert failed.level == Level.WARN and "restarting it" in failed.message
    assert _events(bus, "speech/heard", 1)[0].data["text"] == "go to the charging dock"
    assert commands == ["go to the charging dock"]
