"""A recogniser (and the spoken stop's spotter) in its own process, behind the same `transcribe` interface.

Why: pocketsphinx holds the interpreter lock while it decodes, up to 85 ms for one command (measured with a 1 ms
ticker thread beside it). In the robot worker's process that would stall the control loop for eight ticks. The
worker is itself a daemon process, which multiprocessing forbids to have children, so this is a plain
subprocess (`python -m robot.speech.recognizer_process`) speaking pickles over its stdin and stdout.
"""

from __future__ import annotations

import os
import pickle
import select
import struct
import subprocess
import sys
import threading
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from robot.control.priority import ordinary_priority
from robot.speech.asr import ASRError, Transcript
from robot.speech.audio import Audio
from robot.speech.stop_word import StopVerdict

if TYPE_CHECKING:
    from robot.planning.world_context import WorldContext

STARTUP_TIMEOUT_S = 60.0
_HEADER = struct.Struct("<I")


class RecognizerGone(ASRError):
    """The recogniser's process had exited (killed, crashed): a new one can take the same utterance."""


def _send(stream: IO[bytes], message: Any) -> None:
    data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data)) + data)
    stream.flush()


def _receive(stream: IO[bytes]) -> Any:
    header = stream.read(_HEADER.size)
    if len(header) < _HEADER.size:
        raise EOFError("the recogniser process has gone")
    (length,) = _HEADER.unpack(header)
    return pickle.loads(stream.read(length))


class RecognizerProcess:
    """`transcribe` as in-process engines, decoded in a child process (started here; `close()` ends it); with
    `spotter`, also the spoken stop's verdict on an utterance (`spot`, or `feed` as it comes and `finish`). An
    engine of "" loads no recogniser (a process for the spotter alone). With `world`, transcripts are read against
    it (`robot.speech.world_reading`)."""

    def __init__(
        self,
        engine: str,
        objects: dict[str, tuple[str, ...]],
        places: dict[str, tuple[str, ...]],
        whisper_model_dir: str = "",
        spotter: bool = False,
        whisper_second_model: str = "auto",
        world: WorldContext | None = None,
    ) -> None:
        from robot.speech.engines import resolve_engine

        engine = resolve_engine(engine, whisper_model_dir) if engine else ""
        self.name = engine or "stop spotter"
        root = str(Path(__file__).resolve().parents[2])  # this source tree, whether installed or not
        self._process = subprocess.Popen(
            [sys.executable, "-m", "robot.speech.recognizer_process"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            cwd=root,
            preexec_fn=ordinary_priority,
        )
        self._lock = threading.Lock()
        assert self._process.stdin is not None and self._process.stdout is not None
        self._in, self._out = self._process.stdin, self._process.stdout
        _send(self._in, (engine, objects, places, whisper_model_dir, spotter, whisper_second_model, world))
        reply = self._reply()
        if reply[0] != "ready":
            self.close()
            raise ASRError(reply[1])

    @property
    def alive(self) -> bool:
        return self._process.poll() is None and not self._out.closed

    @property
    def pid(self) -> int:
        return self._process.pid

    def transcribe(self, audio: Audio, timeout_s: float | None = None) -> Transcript:
        """Raises ASRError when the process has gone, or (then killed) gives no answer within `timeout_s`."""
        return self._ask("transcribe", audio.samples, timeout_s)

    def spot(self, audio: Audio, timeout_s: float | None = None) -> StopVerdict:
        """Whether the utterance is a spoken stop (a process started with `spotter`)."""
        return self._ask("spot", audio.samples, timeout_s)

    def feed(self, samples: Any) -> None:
        """More of an utterance for the spotter, as it is spoken (no answer is waited for)."""
        with self._lock:
            try:
                _send(self._in, ("feed", samples))
            except (OSError, ValueError) as exc:
                raise RecognizerGone(f"the recogniser process has gone: {exc}") from exc

    def finish(self, timeout_s: float | None = None) -> StopVerdict:
        """The spotter's verdict on what was fed since the last `finish`."""
        return self._ask("finish", None, timeout_s)

    def _ask(self, request: str, payload: Any, timeout_s: float | None) -> Any:
        with self._lock:
            try:
                _send(self._in, (request, payload))
                if timeout_s is not None and not select.select([self._out], [], [], timeout_s)[0]:
                    self._process.kill()  # a hung decoder: the next caller gets a new process
                    self._process.wait()
                    raise ASRError(f"the recogniser gave no answer within {timeout_s:g} s: it was stopped")
                reply = self._reply()
            except (OSError, ValueError) as exc:
                raise RecognizerGone(f"the recogniser process has gone: {exc}") from exc
        if reply[0] != "answer":
            raise ASRError(reply[1])
        return reply[1]

    def close(self) -> None:
        if self._process.poll() is None:
            self._in.close()
            try:
                self._process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._out.close()

    def _reply(self) -> tuple[str, Any]:
        try:
            return _receive(self._out)
        except EOFError as exc:
            raise RecognizerGone(f"the recogniser process exited with code {self._process.wait()}") from exc


def _serve(stdin: IO[bytes], stdout: IO[bytes]) -> None:
    from robot.speech.engines import build_recognizer
    from robot.speech.stop_word import StopSpotter

    engine, objects, places, whisper_model_dir, with_spotter, second_model, world = _receive(stdin)
    try:
        recognizer = (
            build_recognizer(engine, objects, places, whisper_model_dir, second_model, world) if engine else None
        )
        spotter = StopSpotter(objects, places) if with_spotter else None
    except ASRError as exc:
        _send(stdout, ("error", str(exc)))
        return
    _send(stdout, ("ready", None))
    while True:
        try:
            request, payload = _receive(stdin)
        except EOFError:
            return
        try:
            if request == "feed":
                spotter.feed(payload)  # no answer: the microphone does not wait while it speaks
                continue
            if request == "transcribe":
                answer: Any = recognizer.transcribe(Audio(payload))
            elif request == "spot":
                answer = spotter.spot(Audio(payload))
            else:
                answer = spotter.finish()
            _send(stdout, ("answer", answer))
        except Exception as exc:  # a decoder error answers; it does not kill the process
            if request != "feed":
                _send(stdout, ("error", f"{type(exc).__name__}: {exc}"))


if __name__ == "__main__":
    # the protocol owns stdout: anything a library prints goes to stderr instead
    protocol_out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    _serve(sys.stdin.buffer, protocol_out)
