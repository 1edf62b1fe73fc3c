"""The robot's microphone and speaker through the real stack: `humanoid serve` opens them with sounddevice
(PortAudio, ALSA) as it would a USB microphone and speaker.

The devices are ALSA `file` plugins defined in the server's ~/.asoundrc: the microphone reads a named pipe that
this test fills in real time (PortAudio paces itself by the pipe, as by a sound card's clock), the speaker writes
what it plays to a file.
"""

from __future__ import annotations

import contextlib
import ctypes.util
import os
import shutil
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from harness.browser import launch_chromium
from harness.server import ServerProcess
from robot.speech.tts import synthesize_audio

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not shutil.which("espeak-ng"), reason="needs espeak-ng"),
    pytest.mark.skipif(not ctypes.util.find_library("portaudio"), reason="needs libportaudio2"),
]

ASOUNDRC = """
pcm.robotmic {{
    type file
    slave.pcm "null"
    file "/dev/null"
    infile "{microphone}"
    format "raw"
}}
pcm.robotspeaker {{
    type file
    slave.pcm "null"
    file "{speaker}"
    format "raw"
}}
"""
BLOCK = 480  # 30 ms at 16 kHz


class RoomMicrophone:
    """Writes quiet room noise into the microphone's pipe in real time, and a sentence when asked."""

    def __init__(self, pipe: Path) -> None:
        self.pipe = pipe
        self._said: list[np.ndarray] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._noise = np.round(np.random.default_rng(1).normal(0, 30, 16000 * 10)).astype(np.int16)
        self.opens = 0

    def __enter__(self) -> RoomMicrophone:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        with contextlib.suppress(OSError):  # a writer blocked in open() waits for a reader: be one
            os.close(os.open(self.pipe, os.O_RDONLY | os.O_NONBLOCK))
        self._thread.join(timeout=5)

    def say(self, samples: np.ndarray) -> None:
        with self._lock:
            self._said.append(samples)

    def _next_block(self, position: int) -> np.ndarray:
        with self._lock:
            if self._said:
                speech = self._said[0]
                block, self._said[0] = speech[:BLOCK], speech[BLOCK:]
                if not len(self._said[0]):
                    self._said.pop(0)
                if len(block) == BLOCK:
                    return block
                return np.concatenate([block, np.zeros(BLOCK - len(block), np.int16)])
        start = position % (len(self._noise) - BLOCK)
        return self._noise[start : start + BLOCK]

    def _run(self) -> None:
        written = 0
        while not self._stop.is_set():
            try:
                with self.pipe.open("wb", buffering=0) as pipe:  # waits for the device to be opened
                    self.opens += 1
                    started, sent = time.monotonic(), 0
                    while not self._stop.is_set():
                        pipe.write(self._next_block(written).astype("<i2").tobytes())
                        written, sent = written + BLOCK, sent + BLOCK
                        time.sleep(max(0.0, started + sent / 16000 - time.monotonic()))
            except (BrokenPipeError, OSError):
                time.sleep(0.01)  # PortAudio opens and closes a device to probe it; the stream opens it again


def test_the_robot_hears_a_command_with_its_microphone_and_answers_aloud(tmp_path) -> None:
    home, pipe, spoken = tmp_path / "home", tmp_path / "microphone.raw", tmp_path / "speaker.raw"
    home.mkdir()
    os.mkfifo(pipe)
    (home / ".asoundrc").write_text(ASOUNDRC.format(microphone=pipe, speaker=spoken))
    # the grammar recogniser: the transcript is then the command's own words (whisper's are tested elsewhere)
    env = {
        "HOME": str(home),
        "HUMANOID_MICROPHONE": "robotmic",
        "HUMANOID_SPEAKER": "robotspeaker",
        "HUMANOID_ASR_ENGINE": "pocketsphinx",
    }
    sync_api = pytest.importorskip("playwright.sync_api")
    with (
        RoomMicrophone(pipe) as room,
        ServerProcess(tmp_path / "server", extra_env=env, views=False) as server,
        sync_api.sync_playwright() as playwright,
    ):
        config = server.get("/api/config")
        assert config["microphone"] == "robot microphone: robotmic (16000 Hz)"
        assert config["speaker"] == "robot speaker: robotspeaker (16000 Hz)"
        browser = launch_chromium(playwright)
        page = browser.new_page()
        page.goto(server.url)
        sync_api.expect(page.locator("#robot-audio")).to_have_text(
            "robot microphone: robotmic (16000 Hz) · robot speaker: robotspeaker (16000 Hz)"
        )
        sync_api.expect(page.locator("#spoken-stop")).to_contain_text("spoken stop on")
        sync_api.expect(page.locator("#conn")).to_contain_text("connected", timeout=20_000)
        room.say(synthesize_audio("go back to where you started", "en-us", 150).samples)
        # the operator sees what the robot heard, and that it is running it
        sync_api.expect(page.locator("#heard")).to_contain_text(
            'the robot heard "go back to where you started"', timeout=30_000
        )
        assert "running" in page.locator("#heard").inner_text()
        browser.close()
        deadline, events = time.monotonic() + 60, []
        while time.monotonic() < deadline:
            events = server.get("/api/events")
            if any(e["kind"] == "plan/finished" for e in events):
                break
            time.sleep(0.5)
        kinds = {e["kind"]: e for e in events}
        assert kinds["speech/heard"]["data"]["text"] == "go back to where you started", [e["message"] for e in events]
        commands = [e for e in events if e["kind"] == "speech/command"]
        assert commands and all(e["data"]["accepted"] for e in commands), [e["message"] for e in events]
        assert kinds["plan/finished"]["data"]["state"] == "succeeded"
        said = next(e for e in events if e["kind"] == "speech/say")["data"]["text"]
        # the robot's answer went out of its speaker: as long as espeak-ng takes to say it, and not silence
        time.sleep(2.0)
        played = np.frombuffer(spoken.read_bytes(), dtype="<i2")
        expected_s = synthesize_audio(said, "en-us").duration_s
        assert abs(len(played) / 16000 - expected_s) < 0.5 and np.abs(played).max() > 3000
        # ... and it did not take its own voice for a command
        assert sum(e["kind"] == "speech/heard" for e in events) == 1
        # the session keeps what the robot heard, with the recording, and the command it ran
        session = server.get(f"/api/sessions/{config['session_id']}")
        transcript = next(t for t in session["transcripts"] if t["source"] == "robot-mic")
        assert transcript["text"] == "go back to where you started"
        audio = httpx.get(server.url + transcript["audio_url"])
        assert audio.status_code == 200 and audio.content.startswith(b"RIFF")
        commands = [(c["source"], c["text"], c["accepted"]) for c in session["commands"]]
        assert commands == [("robot-mic", "go back to where you started", True)]

        # a spoken stop: the robot's own code latches its e-stop, as the button does; release stays explicit
        assert not server.get("/api/state")["estop_latched"]
        room.say(synthesize_audio("stop", "en-gb", 160).samples)
        deadline, latched = time.monotonic() + 30, []
        while time.monotonic() < deadline and not latched:
            latched = [e for e in server.get("/api/events") if e["kind"] == "estop/latched"]
            time.sleep(0.2)
        assert latched and latched[0]["data"]["source"] == "voice", [e["message"] for e in server.get("/api/events")]
        assert server.get("/api/state")["estop_latched"]
