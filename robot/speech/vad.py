"""Cutting a continuous microphone stream into utterances: pocketsphinx's endpointer (a WebRTC-style voice
activity detector with a decision window) decides where speech starts and ends.

Its most aggressive mode is the default: at 10 dB SNR of white noise the loosest mode took the whole stream for
speech (never ending an utterance), the aggressive one still cut espeak-ng commands where they are. A 0.2 s
decision window (0.3 s is pocketsphinx's default) takes 90 ms off the time from the end of a command to its plan
(`humanoid bench voice`: p50 447 -> 355 ms), and still did not split a command at the pauses between its words.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from robot.speech.audio import RATE, Audio

MAX_UTTERANCE_S = 15.0  # a command, not a speech: longer ones are cut (and decoded) at this length
MIN_UTTERANCE_S = 0.3  # shorter bursts (a knock, a click) are no command


class UtteranceDetector:
    """Feed 16 kHz int16 samples in blocks of any size; get back each utterance once its end is heard.

    `on_speech` gets each piece of an utterance as soon as it is known to be speech (the spoken stop's spotter
    decodes while the words come), and `on_discard` is told when the pieces so far are thrown away (too short to be
    a command, or forgotten by `reset`)."""

    def __init__(
        self,
        aggressiveness: int = 3,
        window_s: float = 0.2,
        ratio: float = 0.9,
        on_speech: Callable[[np.ndarray], None] | None = None,
        on_discard: Callable[[], None] | None = None,
    ) -> None:
        from pocketsphinx import Endpointer

        self._endpointer = Endpointer(window=window_s, ratio=ratio, vad_mode=aggressiveness, sample_rate=RATE)
        self._frame = self._endpointer.frame_bytes // 2
        self._pending = np.zeros(0, np.int16)
        self._speech: list[bytes] = []
        self._on_speech = on_speech
        self._on_discard = on_discard

    @property
    def in_speech(self) -> bool:
        return bool(self._endpointer.in_speech)

    def feed(self, samples: np.ndarray) -> Iterator[Audio]:
        """The utterances that ended within `samples` (usually none, sometimes one)."""
        data = np.concatenate([self._pending, np.asarray(samples, dtype=np.int16).ravel()])
        whole = len(data) - len(data) % self._frame
        self._pending = data[whole:]
        for start in range(0, whole, self._frame):
            was_speaking = self._endpointer.in_speech
            speech = self._endpointer.process(data[start : start + self._frame].tobytes())
            if speech is not None:
                self._speech.append(speech)
                if self._on_speech is not None:
                    self._on_speech(np.frombuffer(speech, dtype="<i2").astype(np.int16))
            ended = was_speaking and not self._endpointer.in_speech
            too_long = sum(map(len, self._speech)) >= MAX_UTTERANCE_S * RATE * 2
            if (ended or too_long) and (utterance := self._take()):
                yield utterance

    def reset(self) -> None:
        """Forget what was heard so far (the robot's own voice, while it speaks)."""
        if self._speech and self._on_discard is not None:
            self._on_discard()
        self._speech.clear()
        self._pending = np.zeros(0, np.int16)
        for _ in range(200):  # close an open utterance without keeping it (silence ends one within the window)
            if not self._endpointer.in_speech:
                break
            self._endpointer.process(bytes(self._frame * 2))

    def _take(self) -> Audio | None:
        pcm, self._speech = b"".join(self._speech), []
        samples = np.frombuffer(pcm, dtype="<i2").astype(np.int16)
        if len(samples) >= MIN_UTTERANCE_S * RATE:
            return Audio(samples)
        if len(samples) and self._on_discard is not None:
            self._on_discard()
        return None
