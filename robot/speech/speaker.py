"""The robot's speaker: sentences synthesised by espeak-ng and played through `sounddevice`, one after another.

Playing blocks, so it happens on the speaker's own thread; `say` only queues. Before each sentence plays,
`on_playing(seconds)` lets the microphone stop listening for as long.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any

from robot.speech.audio import Audio, at_rate
from robot.speech.devices import AudioDevice
from robot.speech.tts import TTSError, synthesize_audio

log = logging.getLogger(__name__)

QUEUE_SENTENCES = 20
StreamFactory = Callable[..., Any]  # sounddevice.OutputStream's signature


class Speaker:
    def __init__(
        self,
        device: AudioDevice,
        on_playing: Callable[[float], None] | None = None,
        on_error: Callable[[str], None] | None = None,
        stream_factory: StreamFactory | None = None,
        synthesize: Callable[[str], Audio] = synthesize_audio,
    ) -> None:
        if not device.available:
            raise ValueError(device.describe())
        self.device = device
        self._on_playing = on_playing or (lambda seconds: None)
        self._on_error = on_error or (lambda message: None)
        self._stream_factory = stream_factory
        self._synthesize = synthesize
        self._sentences: queue.Queue[str | None] = queue.Queue(maxsize=QUEUE_SENTENCES)
        self._thread: threading.Thread | None = None
        self.spoken = 0
        self.spoken_s = 0.0

    def start(self) -> None:
        self._thread = threading.Thread(target=self._play_queue, name="robot-speaker", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        if self._thread is not None:
            self._sentences.put(None)
            self._thread.join(timeout=30.0)
            self._thread = None

    def say(self, text: str) -> bool:
        """Queue a sentence; False when 20 are already waiting (the robot does not fall minutes behind)."""
        try:
            self._sentences.put_nowait(text)
            return True
        except queue.Full:
            return False

    def _play_queue(self) -> None:
        while (text := self._sentences.get()) is not None:
            try:
                self._play(self._synthesize(text))
            except TTSError as exc:
                self._on_error(f"cannot synthesise {text!r}: {exc}")
            except Exception as exc:  # PortAudio errors: a device unplugged, busy
                log.exception("playing speech failed")
                self._on_error(f"cannot play on {self.device.name}: {exc}")

    def _play(self, audio: Audio) -> None:
        factory = self._stream_factory
        if factory is None:
            import sounddevice as sd

            factory = sd.OutputStream
        samples = at_rate(audio, self.device.samplerate)
        seconds = len(samples) / self.device.samplerate
        self._on_playing(seconds)
        with factory(samplerate=self.device.samplerate, channels=1, dtype="int16", device=self.device.index) as out:
            out.write(samples.reshape(-1, 1))
        self.spoken += 1
        self.spoken_s += seconds
