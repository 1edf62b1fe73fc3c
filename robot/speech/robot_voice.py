"""The robot's own ears and voice: its microphone heard through the recogniser, its `say` steps spoken through
its speaker. Either may be missing (servers have no sound card): the robot says so once, in an event, and works
on without it (the page's push-to-talk and speech are unaffected).

Events (the worker's bus):
- `speech/microphone`, `speech/speaker` at start: the device used, or why there is none (WARN).
- `speech/heard`: what the microphone heard (text, confidence, in_grammar, engine, audio_s, decode_ms), whether it
  runs unasked (`will_run`), and `audio_path`, the utterance as WAV for the session store to take.
- `speech/command`: the reply to a command the robot ran on hearing it (accepted, command_id, refusal, reply).
"""

from __future__ import annotations

import itertools
import logging
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot.interface import CommandReply, Event, EventSubscription, Level
from robot.speech.asr import ASRError, SpeechRecognizer
from robot.speech.audio import Audio
from robot.speech.devices import AudioDevice, find_device
from robot.speech.microphone import Microphone
from robot.speech.recognizer_process import RecognizerProcess
from robot.speech.speaker import Speaker
from robot.speech.sphinx import AUTO_RUN_CONFIDENCE

log = logging.getLogger(__name__)

ECHO_TAIL_S = 0.4  # the room rings on after the speaker stops
SOURCE = "robot-mic"


@dataclass(frozen=True)
class VoiceConfig:
    microphone: str = "auto"  # "auto" (the default input device), "off", or a device name or index
    speaker: str = "auto"
    engine: str = "pocketsphinx"
    whisper_model_dir: str = ""
    auto_run: bool = True  # run what it hears when the recogniser is sure; else the operator confirms in the page
    spool_dir: str = ""  # where heard utterances wait for the session store ("" = a temporary directory)


class RobotVoice:
    def __init__(
        self,
        config: VoiceConfig,
        objects: dict[str, tuple[str, ...]],
        places: dict[str, tuple[str, ...]],
        publish: Callable[..., Event],
        run_command: Callable[[str], CommandReply],
        subscribe: Callable[[], EventSubscription],
        input_stream: Callable[..., Any] | None = None,  # sounddevice's streams unless given (tests)
        output_stream: Callable[..., Any] | None = None,
        recognizer_factory: Callable[..., SpeechRecognizer] = RecognizerProcess,
    ) -> None:
        self.config = config
        self._objects, self._places = objects, places
        self._publish = publish
        self._run_command = run_command
        self._subscribe = subscribe
        self._input_stream, self._output_stream = input_stream, output_stream
        self._recognizer_factory = recognizer_factory
        self._recognizer: SpeechRecognizer | None = None
        self.microphone: Microphone | None = None
        self.speaker: Speaker | None = None
        self.microphone_status = "not started"
        self.speaker_status = "not started"
        self._spool: tempfile.TemporaryDirectory | None = None
        self._spool_dir = Path(config.spool_dir) if config.spool_dir else None
        self._numbers = itertools.count(1)
        self._says: EventSubscription | None = None
        self._say_thread: threading.Thread | None = None
        self._stopping = threading.Event()

    @property
    def listening(self) -> bool:
        """The microphone is open and a recogniser hears it."""
        return self.microphone is not None and self._recognizer is not None

    # lifecycle

    def start(self, microphone: AudioDevice | None = None, speaker: AudioDevice | None = None) -> None:
        """Open the devices the settings name (or these ones), and say what the robot can hear and say with."""
        self._start_microphone(microphone or find_device("input", self.config.microphone))
        self._start_speaker(speaker or find_device("output", self.config.speaker))

    def stop(self) -> None:
        self._stopping.set()
        if self.microphone is not None:
            self.microphone.stop()
        if self._say_thread is not None:
            self._say_thread.join(timeout=2.0)
        if self._says is not None:
            self._says.close()
        if self.speaker is not None:
            self.speaker.stop()
        if self._recognizer is not None and hasattr(self._recognizer, "close"):
            self._recognizer.close()
        if self._spool is not None:
            self._spool.cleanup()

    def _start_microphone(self, device: AudioDevice) -> None:
        if device.available:
            try:
                # decoding in its own process: in the worker's it would stall the control loop (see there)
                self._recognizer = self._recognizer_factory(self.config.engine, self._objects, self._places,
                                                            self.config.whisper_model_dir)  # fmt: skip
                self.microphone = Microphone(device, self._on_utterance, self._input_stream)
                self.microphone.start()
            except Exception as exc:  # no recogniser (ASRError), or PortAudio cannot open the device
                self.microphone = None
                device = AudioDevice("input", None, "", 0, f"{device.name} cannot be used: {exc}")
        self.microphone_status = device.describe()
        if device.available:
            message = f"{self.microphone_status}: listening ({self.config.engine})"
            self._publish("speech/microphone", message, Level.OK, available=True, device=device.name)
        else:
            quiet = self.config.microphone.strip().lower() == "off"
            self._publish("speech/microphone", f"{self.microphone_status}; voice commands work through the page",
                          Level.OK if quiet else Level.WARN, available=False, reason=device.problem)  # fmt: skip

    def _start_speaker(self, device: AudioDevice) -> None:
        if device.available:
            self.speaker = Speaker(device, self._muting, self._speaker_error, self._output_stream)
            self.speaker.start()
            self._says = self._subscribe()
            self._say_thread = threading.Thread(target=self._forward_says, name="robot-says", daemon=True)
            self._say_thread.start()
        self.speaker_status = device.describe()
        if device.available:
            self._publish("speech/speaker", f"{self.speaker_status}: the robot speaks aloud", Level.OK,
                          available=True, device=device.name)  # fmt: skip
        else:
            quiet = self.config.speaker.strip().lower() == "off"
            self._publish("speech/speaker", f"{self.speaker_status}; the page speaks for the robot",
                          Level.OK if quiet else Level.WARN, available=False, reason=device.problem)  # fmt: skip

    # hearing

    def _on_utterance(self, audio: Audio) -> None:
        if self._recognizer is None:
            return
        try:
            transcript = self._recognizer.transcribe(audio)
        except ASRError as exc:  # the recogniser's process died: say so, start another, and listen on
            self._restart_recognizer(str(exc))
            return
        if not transcript.text:
            return  # a noise, a cough: nothing to show or keep
        sure = transcript.in_grammar and transcript.confidence >= AUTO_RUN_CONFIDENCE
        will_run = sure and self.config.auto_run
        heard = {
            "text": transcript.text,
            "confidence": round(transcript.confidence, 3),
            "in_grammar": transcript.in_grammar,
            "engine": transcript.engine,
            "audio_s": round(transcript.audio_s, 3),
            "decode_ms": round(transcript.decode_s * 1000, 1),
            "auto_run": sure,
            "will_run": will_run,
            "source": SOURCE,
            "audio_path": self._spool_utterance(audio),
        }
        how = "running it" if will_run else "confirm it in the page"
        self._publish("speech/heard", f'the robot heard "{transcript.text}" '
                      f"(confidence {transcript.confidence:.2f}): {how}", Level.OK, **heard)  # fmt: skip
        if will_run:
            reply = self._run_command(transcript.text)
            self._publish("speech/command", reply.message, Level.OK if reply.accepted else Level.WARN,
                          text=transcript.text, source=SOURCE, accepted=reply.accepted, command_id=reply.command_id,
                          refusal=reply.refusal.value if reply.refusal else None, reply=reply.message,
                          errors=list(reply.errors))  # fmt: skip

    def _restart_recognizer(self, problem: str) -> None:
        self._publish("speech/microphone", f"the recogniser failed ({problem}): an utterance was lost; restarting it",
                      Level.WARN, available=True, problem=problem)  # fmt: skip
        if hasattr(self._recognizer, "close"):
            self._recognizer.close()
        try:
            self._recognizer = self._recognizer_factory(self.config.engine, self._objects, self._places,
                                                        self.config.whisper_model_dir)  # fmt: skip
        except Exception as exc:
            self.microphone_status = f"no robot microphone: the recogniser cannot restart ({exc})"
            self._publish("speech/microphone", self.microphone_status, Level.ERROR, available=False, reason=str(exc))
            self._recognizer = None  # the microphone stays open, unheard

    def _spool_utterance(self, audio: Audio) -> str | None:
        try:
            if self._spool_dir is None:
                self._spool = tempfile.TemporaryDirectory(prefix="humanoid-heard-")
                self._spool_dir = Path(self._spool.name)
            self._spool_dir.mkdir(parents=True, exist_ok=True)
            path = self._spool_dir / f"heard-{int(time.time())}-{next(self._numbers)}.wav"
            path.write_bytes(audio.wav_bytes())
            return str(path)
        except OSError as exc:  # a full disk loses the recording, not the command
            log.warning("cannot keep the utterance: %s", exc)
            return None

    # speaking

    def _forward_says(self) -> None:
        assert self._says is not None and self.speaker is not None
        while not self._stopping.is_set():
            event = self._says.get(timeout=0.2)
            if event is None or event.kind != "speech/say":
                continue
            if not self.speaker.say(str(event.data.get("text", event.message))):
                self._speaker_error("20 sentences are already waiting to be spoken: this one is dropped")

    def _muting(self, seconds: float) -> None:
        if self.microphone is not None:
            self.microphone.mute_for(seconds + ECHO_TAIL_S)

    def _speaker_error(self, message: str) -> None:
        self._publish("speech/speaker", message, Level.WARN, available=True, problem=message)
