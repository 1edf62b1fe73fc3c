"""Speaking: espeak-ng synthesises a sentence to WAV on the server (played in the browser, and through
`sounddevice` when the robot has a speaker)."""

from __future__ import annotations

import re
import shutil
import subprocess
from functools import cache
from pathlib import Path

from robot.control.priority import ordinary_priority
from robot.speech.audio import Audio, read_wav_bytes

DEFAULT_VOICE = "en-us"
DEFAULT_WPM = 160
MAX_TEXT_CHARS = 500


class TTSError(Exception):
    """Speech could not be synthesised: the message says why (espeak-ng missing, bad voice)."""


def espeak_available() -> bool:
    return shutil.which("espeak-ng") is not None


def synthesize(text: str, voice: str = DEFAULT_VOICE, words_per_minute: int = DEFAULT_WPM, pitch: int = 50) -> bytes:
    """The sentence as WAV bytes (espeak-ng's 22.05 kHz mono)."""
    if not text.strip():
        raise TTSError("nothing to say")
    if len(text) > MAX_TEXT_CHARS:
        raise TTSError(f"at most {MAX_TEXT_CHARS} characters")
    if not espeak_available():
        raise TTSError("espeak-ng is not installed (apt-get install espeak-ng)")
    check_variant(voice)
    done = subprocess.run(
        ["espeak-ng", "-v", voice, "-s", str(int(words_per_minute)), "-p", str(int(pitch)), "--stdout", text],
        capture_output=True,
        timeout=30,
        check=False,
        preexec_fn=ordinary_priority,
    )
    if done.returncode != 0 or not done.stdout.startswith(b"RIFF"):
        raise TTSError(f"espeak-ng failed: {done.stderr.decode(errors='replace').strip() or done.returncode}")
    return done.stdout


def synthesize_audio(
    text: str, voice: str = DEFAULT_VOICE, words_per_minute: int = DEFAULT_WPM, pitch: int = 50
) -> Audio:
    """As 16 kHz mono, for the recogniser (and its tests)."""
    return read_wav_bytes(synthesize(text, voice, words_per_minute, pitch))


def check_variant(voice: str) -> None:
    """espeak-ng speaks a voice whose variant (after "+") it does not have without it, saying nothing: four voices of
    the spoken test sets were plain accents for that reason (a variant's name is its file's, case and all)."""
    if "+" not in voice:
        return
    variant = voice.split("+", 1)[1]
    known = espeak_variants()
    if known and variant not in known:
        like = sorted(v for v in known if v.lower() == variant.lower()) or sorted(known)[:6]
        raise TTSError(f"espeak-ng has no voice variant {variant!r} (it would speak without it): {', '.join(like)}?")


@cache
def espeak_variants() -> frozenset[str]:
    """The variants espeak-ng has (the files of its data's voices/!v), or nothing when that cannot be read."""
    try:
        version = subprocess.run(["espeak-ng", "--version"], capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return frozenset()
    found = re.search(r"Data at:\s*(\S.*?)\s*$", version.stdout)
    folder = Path(found.group(1)) / "voices" / "!v" if found else None
    if folder is None or not folder.is_dir():
        return frozenset()
    return frozenset(path.name for path in folder.iterdir() if path.is_file())
