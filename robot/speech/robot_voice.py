"""The robot's own ears and voice: its microphone heard through the recogniser, its `say` steps spoken through
its speaker. Either may be missing (servers have no sound card): the robot says so once, in an event, and works
on without it (the page's push-to-talk and speech are unaffected).

Events (the worker's bus):
- `speech/microphone`, `speech/speaker` at start: the device used, or why there is none (WARN).
- `speech/heard`: what the microphone heard (text, confidence, in_grammar, engine, audio_s, decode_ms), whether it
  runs unasked (`will_run`), and `audio_path`, the utterance as WAV for the session store to take.
- `speech/command`: the reply to a command the robot ran on hearing it (accepted, command_id, refusal, reply).
- `speech/stop`: a spoken stop latched the e-stop (phrase, heard, stage: "spotter" as the words ended, or
  "transcript" when only the recogniser's words showed it).

The spoken stop is heard apart from recognition: the microphone hands each piece of speech to the stop spotter's
own process as it comes, so its verdict is ready as the utterance ends, and the robot latches its e-stop itself
(`EStop(source="voice")`) without waiting for the recogniser, which decodes on its own thread.
"""

from __future__ import annotations

import itertools
import logging
import queue
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot.interface import CommandReply, Event, EventSubscription, Level, RunCommand
from robot.planning.world_context import WorldContext
from robot.speech.asr import ASRError, SpeechRecognizer, Transcript
from robot.speech.audio import Audio
from robot.speech.devices import AudioDevice, find_device
from robot.speech.microphone import Microphone
from robot.speech.recognizer_process import RecognizerProcess
from robot.speech.speaker import Speaker
from robot.speech.stop_word import StopVerdict, transcript_is_stop

log = logging.getLogger(__name__)

ECHO_TAIL_S = 0.4  # the room rings on after the speaker stops
SOURCE = "robot-mic"
STOP_SOURCE = "voice"
VERDICT_TIMEOUT_S = 2.0  # the spotter's verdict normally takes milliseconds: a hung spotter is restarted


@dataclass(frozen=True)
class VoiceConfig:
    microphone: str = "auto"  # "auto" (the default input device), "off", or a device name or index
    speaker: str = "auto"
    engine: str = "auto"  # whisper when it is installed, else pocketsphinx
    whisper_model_dir: str = ""
    whisper_second_model: str = "auto"  # hears again what whisper's model is not sure of ("off": none)
    auto_run: bool = True  # run what it hears when the recogniser is sure; else the operator confirms in the page
    spoken_stop: bool = True  # a spoken "stop" (alone, or with a few words) latches the e-stop
    spool_dir: str = ""  # where heard utterances wait for the session store ("" = a temporary directory)


class RobotVoice:
    def __init__(
        self,
        config: VoiceConfig,
        objects: dict[str, tuple[str, ...]],
        places: dict[str, tuple[str, ...]],
        publish: Callable[..., Event],
        run_command: Callable[[RunCommand], CommandReply],
        subscribe: Callable[[], EventSubscription],
        input_stream: Callable[..., Any] | None = None,  # sounddevice's streams unless given (tests)
        output_stream: Callable[..., Any] | None = None,
        recognizer_factory: Callable[..., SpeechRecognizer] = RecognizerProcess,
        estop: Callable[[], CommandReply] | None = None,  # latches the e-stop (source "voice")
        world: WorldContext | None = None,  # transcripts are read against it (`robot.speech.world_reading`)
    ) -> None:
        self.config = config
        self._objects, self._places, self._world = objects, places, world
        self._publish = publish
        self._run_command = run_command
        self._subscribe = subscribe
        self._input_stream, self._output_stream = input_stream, output_stream
        self._recognizer_factory = recognizer_factory
        self._recognizer: SpeechRecognizer | None = None
        self._spotter: RecognizerProcess | None = None
        self._estop = estop
        self._heard: queue.Queue[tuple[Audio, bool] | None] = queue.Queue(maxsize=20)
        self._hearing: threading.Thread | None = None
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

    @property
    def spoken_stop(self) -> bool:
        """A spoken stop is listened for (the setting is on, and the spotter runs)."""
        return self._spotter is not None

    def stop(self) -> None:
        self._stopping.set()
        if self.microphone is not None:
            self.microphone.stop()
        if self._hearing is not None:
            self._heard.put(None)
            self._hearing.join(timeout=10.0)
        if self._spotter is not None:
            self._spotter.close()
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
                self._recognizer = self._recognizer_factory(
                    self.config.engine,
                    self._objects,
                    self._places,
                    self.config.whisper_model_dir,
                    whisper_second_model=self.config.whisper_second_model,
                    world=self._world,
                )
                if self.config.spoken_stop and self._estop is not None:
                    self._spotter = RecognizerProcess("", self._objects, self._places, spotter=True)
                self._hearing = threading.Thread(target=self._hear_queue, name="robot-hearing", daemon=True)
                self._hearing.start()
                self.microphone = Microphone(
                    device,
                    self._on_utterance,
                    self._input_stream,
                    on_speech=self._spot_speech,
                    on_discard=self._spot_discard,
                )
                self.microphone.start()
            except Exception as exc:  # no recogniser (ASRError), or PortAudio cannot open the device
                self.microphone = None
                device = AudioDevice("input", None, "", 0, f"{device.name} cannot be used: {exc}")
        self.microphone_status = device.describe()
        if device.available:
            stop = "; a spoken stop latches the e-stop" if self.spoken_stop else ""
            engine = getattr(self._recognizer, "name", self.config.engine)
            message = f"{self.microphone_status}: listening ({engine}){stop}"
            self._publish(
                "speech/microphone", message, Level.OK, available=True, device=device.name, spoken_stop=self.spoken_stop
            )
        else:
            quiet = self.config.microphone.strip().lower() == "off"
            self._publish(
                "speech/microphone",
                f"{self.microphone_status}; voice commands work through the page",
                Level.OK if quiet else Level.WARN,
                available=False,
                reason=device.problem,
            )

    def _start_speaker(self, device: AudioDevice) -> None:
        if device.available:
            self.speaker = Speaker(device, self._muting, self._speaker_error, self._output_stream)
            self.speaker.start()
            self._says = self._subscribe()
            self._say_thread = threading.Thread(target=self._forward_says, name="robot-says", daemon=True)
            self._say_thread.start()
        self.speaker_status = device.describe()
        if device.available:
            self._publish(
                "speech/speaker",
                f"{self.speaker_status}: the robot speaks aloud",
                Level.OK,
                available=True,
                device=device.name,
            )
        else:
            quiet = self.config.speaker.strip().lower() == "off"
            self._publish(
                "speech/speaker",
                f"{self.speaker_status}; the page speaks for the robot",
                Level.OK if quiet else Level.WARN,
                available=False,
                reason=device.problem,
            )

    # hearing

    def _spot_speech(self, samples) -> None:
        """Microphone thread: a piece of speech, for the spotter to decode while the words come."""
        if self._spotter is not None:
            try:
                self._spotter.feed(samples)
            except ASRError as exc:
                self._restart_spotter(str(exc))

    def _spot_discard(self) -> None:
        if self._spotter is not None:
            try:
                self._spotter.finish(VERDICT_TIMEOUT_S)
            except ASRError as exc:
                self._restart_spotter(str(exc))

    def _on_utterance(self, audio: Audio) -> None:
        """Microphone thread: the utterance has ended. A stop latches now; recognition goes to its own thread."""
        verdict = None
        if self._spotter is not None:
            try:
                verdict = self._spotter.finish(VERDICT_TIMEOUT_S)
            except ASRError as exc:
                self._restart_spotter(str(exc))
        spotted = verdict is not None and verdict.stop
        if spotted:
            self._latch(verdict.heard or " ".join(s.phrase for s in verdict.spotted), "spotter", verdict)
        try:
            self._heard.put_nowait((audio, spotted))
        except queue.Full:
            log.warning("the recogniser is 20 utterances behind: one is dropped")

    def _latch(self, heard: str, stage: str, verdict: StopVerdict | None = None) -> None:
        assert self._estop is not None
        reply = self._estop()
        self._publish(
            "speech/stop",
            f'the robot heard "{heard}": e-stop latched ({reply.message})',
            Level.WARN,
            heard=heard,
            stage=stage,
            source=SOURCE,
            accepted=reply.accepted,
            verdict=verdict.as_dict() if verdict else None,
        )

    def _hear_queue(self) -> None:
        while (item := self._heard.get()) is not None:
            try:
                self._hear(*item)
            except Exception:  # one bad utterance must not deafen the robot
                log.exception("handling an utterance failed")

    def _hear(self, audio: Audio, spotted_stop: bool) -> None:
        if self._recognizer is None:
            return
        try:
            transcript = self._recognizer.transcribe(audio)
        except ASRError as exc:  # the recogniser's process died: say so, start another, and listen on
            self._restart_recognizer(str(exc))
            return
        if not transcript.text:
            return  # a noise, a cough: nothing to show or keep
        late_stop = self.spoken_stop and not spotted_stop and transcript_is_stop(transcript)
        stop = spotted_stop or late_stop
        will_run = transcript.sure and self.config.auto_run and not stop
        heard = {**self._heard_data(transcript, audio, will_run), "stop": stop}
        how = "a spoken stop" if stop else "running it" if will_run else "confirm it in the page"
        self._publish(
            "speech/heard",
            f'the robot heard "{transcript.text}" (confidence {transcript.confidence:.2f}): {how}',
            Level.OK,
            **heard,
        )
        if late_stop:
            self._latch(transcript.text, "transcript")
        elif will_run:
            reply = self._run_command(RunCommand(transcript.text, transcript.alternatives))
            self._publish(
                "speech/command",
                reply.message,
                Level.OK if reply.accepted else Level.WARN,
                text=transcript.text,
                source=SOURCE,
                accepted=reply.accepted,
                command_id=reply.command_id,
                refusal=reply.refusal.value if reply.refusal else None,
                reply=reply.message,
                errors=list(reply.errors),
            )

    def _heard_data(self, transcript: Transcript, audio: Audio, will_run: bool) -> dict[str, Any]:
        return {
            "text": transcript.text,
            "confidence": round(transcript.confidence, 3),
            "in_grammar": transcript.in_grammar,
            "engine": transcript.engine,
            "audio_s": round(transcript.audio_s, 3),
            "decode_ms": round(transcript.decode_s * 1000, 1),
            "alternatives": list(transcript.alternatives),
            "unsure_names": list(transcript.unsure_names),
            "heard_again": transcript.heard_again,
            "first_heard": transcript.first_heard,
            "auto_run": transcript.sure,
            "will_run": will_run,
            "source": SOURCE,
            "audio_path": self._spool_utterance(audio),
        }

    def _restart_spotter(self, problem: str) -> None:
        self._publish(
            "speech/microphone",
            f"the stop spotter failed ({problem}): restarting it",
            Level.WARN,
            available=True,
            problem=problem,
        )
        if self._spotter is not None:
            self._spotter.close()
        try:
            self._spotter = RecognizerProcess("", self._objects, self._places, spotter=True)
        except Exception as exc:
            self._spotter = None
            self._publish(
                "speech/microphone",
                f"no spoken stop: the spotter cannot restart ({exc})",
                Level.ERROR,
                available=True,
                reason=str(exc),
            )

    def _restart_recognizer(self, problem: str) -> None:
        self._publish(
            "speech/microphone",
            f"the recogniser failed ({problem}): an utterance was lost; restarting it",
            Level.WARN,
            available=True,
            problem=problem,
        )
        if hasattr(self._recognizer, "close"):
            self._recognizer.close()
        try:
            self._recognizer = self._recognizer_factory(
                self.config.engine,
                self._objects,
                self._places,
                self.config.whisper_model_dir,
                whisper_second_model=self.config.whisper_second_model,
                world=self._world,
            )
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
