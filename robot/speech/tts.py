"""Speaking: espeak-ng synthesises a sentence to WAV on the server (played in the browser, and through
`sounddevice` when the robot has a speaker)."""

from __future__ import annotations

import shutil
import subprocess

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
