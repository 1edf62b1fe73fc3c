"""The robot's microphone: a `sounddevice` input stream cut into utterances by voice-activity detection.

PortAudio calls back on its own thread with each block; the block is only queued there. A listening thread
resamples it (when the device does not take 16 kHz), finds utterances, and hands each to `on_utterance`, which
may take its time (decoding): the queue holds the audio meanwhile. While the robot speaks, the microphone is
muted so that it does not obey its own voice.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.speech.audio import RATE, Audio, from_samples
from robot.speech.devices import AudioDevice
from robot.speech.vad import UtteranceDetector

log = logging.getLogger(__name__)

BLOCK_S = 0.03
QUEUE_BLOCKS = 2000  # one minute of audio waiting for the decoder before the oldest is dropped
StreamFactory = Callable[..., Any]  # sounddevice.InputStream's signature


class Microphone:
    def __init__(
        self,
        device: AudioDevice,
        on_utterance: Callable[[Audio], None],
        stream_factory: StreamFactory | None = None,
        detector: UtteranceDetector | None = None,
        on_speech: Callable[[np.ndarray], None] | None = None,
        on_discard: Callable[[], None] | None = None,
    ) -> None:
        if not device.available:
            raise ValueError(device.describe())
        self.device = device
        self._on_utterance = on_utterance
        self._stream_factory = stream_factory
        self._detector = detector or UtteranceDetector(on_speech=on_speech, on_discard=on_discard)
        self._blocks: queue.Queue[np.ndarray] = queue.Queue(maxsize=QUEUE_BLOCKS)
        self._stream: Any = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._muted_until = 0.0
        self.dropped_blocks = 0  # the decoder fell a minute behind
        self.stream_problems = 0  # PortAudio's input overflows
        self.utterances = 0

    def start(self) -> None:
        """Open the device (raises sounddevice.PortAudioError when it cannot) and start listening."""
        factory = self._stream_factory
        if factory is None:
            import sounddevice as sd

            factory = sd.InputStream
        self._stop.clear()
        self._stream = factory(
            samplerate=self.device.samplerate,
            channels=1,
            dtype="int16",
            device=self.device.index,
            blocksize=int(self.device.samplerate * BLOCK_S),
            callback=self._callback,
        )
        self._thread = threading.Thread(target=self._listen, name="robot-microphone", daemon=True)
        self._thread.start()
        self._stream.start()

    def stop(self) -> None:
        self._stop.set()
        if self._stream is not None:
            with contextlib.suppress(Exception):  # a device that vanished cannot be closed cleanly
                self._stream.stop()
                self._stream.close()
            self._stream = None
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    def mute_for(self, seconds: float) -> None:
        """Ignore what the microphone hears for `seconds` from now (the robot's own voice)."""
        self._muted_until = max(self._muted_until, time.monotonic() + seconds)

    def _callback(self, indata: np.ndarray, frames: int, time_info: Any, status: Any) -> None:
        if status:
            self.stream_problems += 1
        try:
            self._blocks.put_nowait(indata[:, 0].copy())
        except queue.Full:
            self.dropped_blocks += 1

    def _listen(self) -> None:
        while not self._stop.is_set():
            try:
                block = self._blocks.get(timeout=0.1)
            except queue.Empty:
                continue
            if time.monotonic() < self._muted_until:
                self._detector.reset()
                continue
            if self.device.samplerate != RATE:
                block = from_samples(block, self.device.samplerate).samples
            for utterance in self._detector.feed(block):
                self.utterances += 1
                try:
                    self._on_utterance(utterance)
                except Exception:  # one bad utterance must not deafen the robot
                    log.exception("handling an utterance failed")
