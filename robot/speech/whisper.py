"""faster-whisper with a model directory the user supplies (CTranslate2 format; weights cannot be downloaded at
run time here): free speech, no grammar. An optional extra: `pip install faster-whisper`."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path

import numpy as np

from robot.speech.asr import ASRError, Transcript
from robot.speech.audio import Audio


class WhisperASR:
    name = "whisper"

    def __init__(self, model_dir: str, threads: int = 2) -> None:
        path = Path(model_dir).expanduser()
        if not model_dir or not (path / "model.bin").is_file():
            raise ASRError(f"no faster-whisper model in {model_dir!r} (a CTranslate2 directory with model.bin; set "
                           "HUMANOID_WHISPER_MODEL_DIR)")  # fmt: skip
        try:
            from faster_whisper import WhisperModel
        except ImportError as exc:
            raise ASRError("faster-whisper is not installed (pip install faster-whisper)") from exc
        self._model = WhisperModel(str(path), device="cpu", compute_type="int8", cpu_threads=threads)
        self._lock = threading.Lock()

    def transcribe(self, audio: Audio) -> Transcript:
        started = time.perf_counter()
        with self._lock:
            segments, _ = self._model.transcribe(audio.samples.astype(np.float32) / 32768.0, language="en",
                                                 beam_size=1, vad_filter=False)  # fmt: skip
            segments = list(segments)
        text = " ".join(s.text.strip() for s in segments).strip()
        # the mean per-token log probability, as a probability: whisper's own measure of how sure it is
        confidence = math.exp(float(np.mean([s.avg_logprob for s in segments]))) if segments else 0.0
        return Transcript(text, confidence, self.name, False, audio.duration_s, time.perf_counter() - started)
