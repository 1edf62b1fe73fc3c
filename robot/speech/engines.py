"""Which recogniser: pocketsphinx with the world's command grammar (default), or faster-whisper."""

from __future__ import annotations

from typing import Literal

from robot.speech.asr import ASRError, SpeechRecognizer

Engine = Literal["pocketsphinx", "whisper"]
ENGINES: tuple[Engine, ...] = ("pocketsphinx", "whisper")


def build_recognizer(engine: str, objects: dict[str, tuple[str, ...]], places: dict[str, tuple[str, ...]],
                     whisper_model_dir: str = "") -> SpeechRecognizer:  # fmt: skip
    if engine == "pocketsphinx":
        from robot.speech.sphinx import PocketSphinxASR

        return PocketSphinxASR(objects, places)
    if engine == "whisper":
        from robot.speech.whisper import WhisperASR

        return WhisperASR(whisper_model_dir)
    raise ASRError(f"unknown speech engine {engine!r} (known: {', '.join(ENGINES)})")
