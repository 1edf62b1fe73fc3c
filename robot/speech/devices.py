"""Finding the robot's microphone and speaker through `sounddevice` (PortAudio), and saying plainly why there is
none: servers have no sound card, and a missing PortAudio library must not stop the app.

A device setting is "auto" (the system's default device, if it has one), "off", or a device name (a substring, as
`sounddevice` matches names) or index.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from robot.speech.audio import RATE

Direction = Literal["input", "output"]


@dataclass(frozen=True)
class AudioDevice:
    """A device that can be opened (`index` is PortAudio's), or none and why (`index` None)."""

    direction: Direction
    index: int | None
    name: str
    samplerate: int  # what to open it at: 16 kHz when the device takes it, else its own default rate
    problem: str = ""  # why there is no device ("" when there is one)

    @property
    def available(self) -> bool:
        return self.index is not None

    def describe(self) -> str:
        role = "microphone" if self.direction == "input" else "speaker"
        if self.available:
            return f"robot {role}: {self.name} ({self.samplerate} Hz)"
        return f"no robot {role}: {self.problem}"


def _none(direction: Direction, problem: str) -> AudioDevice:
    return AudioDevice(direction, None, "", 0, problem)


def find_device(direction: Direction, setting: str = "auto") -> AudioDevice:
    """The device `setting` names for `direction`, or an unavailable one saying why."""
    setting = (setting or "auto").strip()
    if setting.lower() == "off":
        return _none(direction, "off by setting")
    try:
        import sounddevice as sd
    except (ImportError, OSError) as exc:  # OSError: the PortAudio library is missing
        return _none(direction, f"sounddevice cannot load PortAudio ({exc}); apt-get install libportaudio2")
    channels = "max_input_channels" if direction == "input" else "max_output_channels"
    try:
        devices = [d for d in sd.query_devices() if d[channels] > 0]
        if not devices:
            return _none(direction, f"the system has no audio {direction} device")
        if setting.lower() == "auto":
            info = sd.query_devices(kind=direction)
        else:
            info = sd.query_devices(int(setting) if setting.isdigit() else setting, kind=direction)
    except (ValueError, sd.PortAudioError) as exc:
        names = ", ".join(repr(d["name"]) for d in devices)
        wanted = "no default" if setting.lower() == "auto" else f"no {setting!r}"
        return _none(direction, f"{wanted} {direction} device ({exc}); the system has: {names}")
    index = int(info["index"])
    check = sd.check_input_settings if direction == "input" else sd.check_output_settings
    try:
        check(device=index, channels=1, dtype="int16", samplerate=RATE)
        rate = RATE
    except (ValueError, sd.PortAudioError):
        rate = int(info["default_samplerate"])  # opened at its own rate; the audio is resampled
    return AudioDevice(direction, index, str(info["name"]), rate)
