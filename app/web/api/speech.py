"""Speech for the page: a push-to-talk recording in, its transcript out; a sentence in, spoken WAV out."""

from __future__ import annotations

import logging
import threading
import time
from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Query, Request, Response
from fastapi.concurrency import run_in_threadpool

from app.runtime import Runtime
from app.sessions.audio_store import save_recording
from app.web.api.deps import Operator, runtime
from app.web.robot_calls import ask
from robot.interface import EStop
from robot.model.world import generate_world
from robot.planning.world_context import WorldContext
from robot.speech.asr import ASRError
from robot.speech.audio import AudioError, from_pcm16, read_wav_bytes
from robot.speech.recognizer_process import RecognizerGone, RecognizerProcess
from robot.speech.stop_word import transcript_is_stop
from robot.speech.tts import MAX_TEXT_CHARS, TTSError, synthesize

log = logging.getLogger(__name__)
router = APIRouter(prefix="/api/speech", tags=["speech"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]
MAX_AUDIO_BYTES = 1024 * 1024  # 32 s of 16 kHz 16-bit speech: a command, not a speech

_recognizers: dict[tuple[str, int], RecognizerProcess] = {}
_recognizers_lock = threading.Lock()


def recognizer(rt: Runtime) -> RecognizerProcess:
    """One recogniser process (with the spoken stop's spotter) per engine and world, started again when it has died
    or was stopped for hanging. In its own process: a decoder holds the interpreter lock (up to 85 ms a command),
    which would stall every WebSocket, the e-stop's included; and a hung or crashed decoder must not take the server
    with it."""
    key = (rt.settings.asr_engine, rt.settings.seed)
    with _recognizers_lock:
        current = _recognizers.get(key)
        if current is None or not current.alive:
            if current is not None:
                log.warning("the speech recogniser process had stopped: starting a new one")
                current.close()
            world = WorldContext.from_layout(generate_world(rt.settings.seed))
            _recognizers[key] = RecognizerProcess(
                rt.settings.asr_engine,
                world.objects,
                world.places,
                rt.settings.whisper_model_dir,
                spotter=True,
                whisper_second_model=rt.settings.whisper_second_model,
                world=world,
            )
        return _recognizers[key]


def close_recognizers() -> None:
    with _recognizers_lock:
        for process in _recognizers.values():
            process.close()
        _recognizers.clear()


@router.post("/transcribe", dependencies=[Operator])
async def transcribe(request: Request, rt: RuntimeDep) -> dict[str, Any]:
    """The body is a WAV file, or raw 16-bit little-endian PCM (`Content-Type: audio/L16; rate=16000`, as the
    page's push-to-talk sends). 422 for audio that cannot be read; 503 when the engine cannot run.

    With the spoken stop on (HUMANOID_SPOKEN_STOP), a recording that is a stop phrase (alone or with a few words)
    latches the e-stop before it is transcribed, as the button does (`stop_word` true, `estop` the reply); the
    transcript's words can show it too. "Stop" inside a longer command is an ordinary command."""
    body = await request.body()
    content_type = request.headers.get("content-type", "").lower()
    try:
        if content_type.startswith("audio/l16"):
            rate = _rate(content_type)
            audio = from_pcm16(body, rate)
        else:
            audio = read_wav_bytes(body)
    except AudioError as exc:
        raise HTTPException(422, detail={"message": f"cannot read the audio: {exc}"}) from exc
    if audio.duration_s < 0.2:
        raise HTTPException(
            422, detail={"message": "the recording is shorter than 0.2 s: hold the button while speaking"}
        )
    # kept with the session before anything can fail: what the operator said is never lost
    path = save_recording(rt.settings.audio_dir, rt.recorder.session_id, audio.wav_bytes())
    latched = None
    try:
        for attempt in (1, 2):  # a recogniser that had died (or died on it) hands the recording to a new one, once
            engine = await run_in_threadpool(recognizer, rt)
            try:
                if rt.settings.spoken_stop:
                    verdict = await run_in_threadpool(engine.spot, audio, rt.settings.asr_timeout_s)
                    if verdict.stop and latched is None:
                        latched = await _latch(rt)
                transcript = await run_in_threadpool(engine.transcribe, audio, rt.settings.asr_timeout_s)
                break
            except RecognizerGone as exc:
                if attempt == 2:
                    raise
                log.warning("%s: the recording goes to a new recogniser", exc)
    except ASRError as exc:
        log.error("speech recognition failed: %s", exc)
        rt.recorder.record_transcript(_unheard(audio.duration_s, rt.settings.asr_engine), "browser", path)
        raise HTTPException(503, detail={"message": f"speech recognition failed: {exc}"}) from exc
    if latched is None and rt.settings.spoken_stop and transcript_is_stop(transcript):
        latched = await _latch(rt)
    heard = {
        "text": transcript.text,
        "confidence": round(transcript.confidence, 3),
        "in_grammar": transcript.in_grammar,
        "engine": transcript.engine,
        "audio_s": round(transcript.audio_s, 3),
        "decode_ms": round(transcript.decode_s * 1000, 1),
        # other wordings nearly as likely: sent with the command, tried when the text cannot be planned
        "alternatives": list(transcript.alternatives),
        # the world's names the audio alone barely supports (the hints put them there): why it is not sure
        "unsure_names": list(transcript.unsure_names),
        "heard_again": transcript.heard_again,
        # whisper's likeliest wording when `text` is a likelier command of the world's (then never auto_run)
        "first_heard": transcript.first_heard,
        # the page runs it without asking when its operator allows that and the recogniser is this sure
        "auto_run": transcript.sure and latched is None,
        "stop_word": latched is not None,
        "estop": latched,
    }
    rt.recorder.record_transcript(heard, "browser", path)
    return heard


async def _latch(rt: Runtime) -> str:
    """The e-stop, latched as the button latches it; its reply's message."""
    reply = await ask(rt.worker, EStop(source="voice", relayed_at_s=time.time()))
    return reply.message


def _unheard(audio_s: float, engine: str) -> dict[str, Any]:
    """A recording the recogniser failed on: kept in the session with an empty transcript."""
    return {
        "text": "",
        "confidence": 0.0,
        "in_grammar": False,
        "engine": engine,
        "audio_s": round(audio_s, 3),
        "decode_ms": 0.0,
    }


@router.get("/say.wav")
def say(text: Annotated[str, Query(min_length=1, max_length=MAX_TEXT_CHARS)]) -> Response:
    """The sentence spoken by espeak-ng, as WAV (the page plays the robot's `say` steps with it)."""
    try:
        return Response(synthesize(text), media_type="audio/wav", headers={"Cache-Control": "max-age=3600"})
    except TTSError as exc:
        raise HTTPException(503 if "not installed" in str(exc) else 422, detail={"message": str(exc)}) from exc


def _rate(content_type: str) -> int:
    for part in content_type.split(";")[1:]:
        key, _, value = part.strip().partition("=")
        if key == "rate":
            if not value.isdigit() or not 8000 <= int(value) <= 96000:
                raise AudioError(f"unsupported sample rate {value!r}")
            return int(value)
    return 16000
