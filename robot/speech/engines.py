"""Which recogniser: faster-whisper (free speech, the default when it and its model are installed) or pocketsphinx
with the world's command grammar (always there: the fallback)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from robot.speech.asr import ASRError, SpeechRecognizer

if TYPE_CHECKING:
    from robot.planning.world_context import WorldContext

Engine = Literal["auto", "pocketsphinx", "whisper"]
ENGINES: tuple[Engine, ...] = ("auto", "pocketsphinx", "whisper")


def resolve_engine(engine: str, whisper_model_dir: str = "") -> str:
    """ "auto" is whisper when faster-whisper and a model are installed, else pocketsphinx; others are themselves."""
    if engine != "auto":
        return engine
    from robot.speech.whisper import whisper_installed

    return "whisper" if whisper_installed(whisper_model_dir) else "pocketsphinx"


def build_recognizer(
    engine: str,
    objects: dict[str, tuple[str, ...]],
    places: dict[str, tuple[str, ...]],
    whisper_model_dir: str = "",
    whisper_second_model: str = "auto",
    world: WorldContext | None = None,
) -> SpeechRecognizer:
    """`whisper_second_model`: what hears again what whisper's model is not sure of (see `WhisperASR`). With `world`,
    transcripts are read against it: the likeliest wording that is one of its commands (`read_in_world`)."""
    recognizer = _engine(
        resolve_engine(engine, whisper_model_dir), objects, places, whisper_model_dir, whisper_second_model
    )
    if world is None:
        return recognizer
    from robot.speech.world_reading import WorldReadRecognizer

    return WorldReadRecognizer(recognizer, world)


def _engine(
    engine: str,
    objects: dict[str, tuple[str, ...]],
    places: dict[str, tuple[str, ...]],
    whisper_model_dir: str,
    whisper_second_model: str,
) -> SpeechRecognizer:
    if engine == "pocketsphinx":
        from robot.speech.sphinx import PocketSphinxASR

        return PocketSphinxASR(objects, places)
    if engine == "whisper":
        from robot.speech.whisper import WhisperASR

        return WhisperASR(whisper_model_dir, objects, places, second_model=whisper_second_model)
    raise ASRError(f"unknown speech engine {engine!r} (known: {', '.join(ENGINES)})")
