"""Audio as the ASR engines want it: 16 kHz mono 16-bit PCM, from WAV files (others through PyAV when present)
or from raw samples at any rate."""

from __future__ import annotations

import io
import wave
from dataclasses import dataclass
from pathlib import Path

import numpy as np

RATE = 16000


class AudioError(ValueError):
    """The audio cannot be read: the message says what is wrong with it."""


@dataclass(frozen=True)
class Audio:
    samples: np.ndarray  # int16, mono, at RATE

    @property
    def duration_s(self) -> float:
        return len(self.samples) / RATE

    def pcm(self) -> bytes:
        return self.samples.astype("<i2").tobytes()

    def wav_bytes(self) -> bytes:
        buffer = io.BytesIO()
        with wave.open(buffer, "wb") as out:
            out.setnchannels(1)
            out.setsampwidth(2)
            out.setframerate(RATE)
            out.writeframes(self.pcm())
        return buffer.getvalue()


def from_samples(samples: np.ndarray, rate: int) -> Audio:
    """Float (-1..1) or int16 samples, mono or (n, channels), at `rate`, as 16 kHz mono int16."""
    data = np.asarray(samples)
    if data.ndim == 2:
        data = data.mean(axis=1)
    if data.ndim != 1:
        raise AudioError(f"audio must be mono or (samples, channels), not shape {data.shape}")
    floats = data.astype(np.float64) / 32768.0 if data.dtype == np.int16 else data.astype(np.float64)
    if rate != RATE and len(floats):
        floats = _resample(floats, rate, RATE)
    return Audio(np.clip(np.round(floats * 32768.0), -32768, 32767).astype(np.int16))  # int16 in: unchanged


def from_pcm16(pcm: bytes, rate: int = RATE) -> Audio:
    if len(pcm) % 2:
        raise AudioError("16-bit PCM needs an even number of bytes")
    return from_samples(np.frombuffer(pcm, dtype="<i2"), rate)


def read_audio(path: str | Path) -> Audio:
    """A WAV file (8/16/32-bit PCM, any rate, any channels), or another format when PyAV is installed."""
    path = Path(path)
    if not path.is_file():
        raise AudioError(f"no such audio file: {path}")
    try:
        return read_wav_bytes(path.read_bytes())
    except AudioError:
        if path.suffix.lower() == ".wav":
            raise
    return _read_with_pyav(path)


def read_wav_bytes(data: bytes) -> Audio:
    try:
        with wave.open(io.BytesIO(data), "rb") as wav:
            width, channels, rate = wav.getsampwidth(), wav.getnchannels(), wav.getframerate()
            frames = wav.readframes(wav.getnframes())
    except (wave.Error, EOFError) as exc:
        raise AudioError(f"not a PCM WAV file: {exc}") from exc
    dtypes = {1: np.uint8, 2: np.dtype("<i2"), 4: np.dtype("<i4")}
    if width not in dtypes:
        raise AudioError(f"unsupported WAV sample width: {8 * width} bits")
    samples = np.frombuffer(frames, dtype=dtypes[width]).astype(np.float64)
    samples = (samples - 128.0) / 128.0 if width == 1 else samples / float(2 ** (8 * width - 1))
    return from_samples(samples.reshape(-1, channels), rate)


def _read_with_pyav(path: Path) -> Audio:
    try:
        import av
    except ImportError as exc:
        raise AudioError(f"{path.name}: only WAV is read without PyAV (pip install av)") from exc
    try:
        with av.open(str(path)) as container:
            resampler = av.AudioResampler(format="s16", layout="mono", rate=RATE)
            chunks = [
                frame.to_ndarray().reshape(-1)
                for decoded in container.decode(audio=0)
                for frame in resampler.resample(decoded)
            ]
    except Exception as exc:  # PyAV raises its own error types per container
        raise AudioError(f"{path.name}: cannot decode: {exc}") from exc
    return Audio(np.concatenate(chunks).astype(np.int16) if chunks else np.zeros(0, np.int16))


def at_rate(audio: Audio, rate: int) -> np.ndarray:
    """The samples as int16 at another rate (for a speaker that does not take 16 kHz)."""
    if rate == RATE or not len(audio.samples):
        return audio.samples
    floats = _resample(audio.samples.astype(np.float64), RATE, rate)
    return np.clip(np.round(floats), -32768, 32767).astype(np.int16)


def _resample(samples: np.ndarray, rate: int, target: int) -> np.ndarray:
    """Band-limited resampling: a windowed-sinc low-pass below the lower Nyquist frequency, then interpolation."""
    if target < rate:
        cutoff = 0.5 * target / rate * 0.95
        taps = np.arange(-32, 33)
        kernel = 2 * cutoff * np.sinc(2 * cutoff * taps) * np.hamming(len(taps))
        samples = np.convolve(samples, kernel / kernel.sum(), mode="same")
    positions = np.arange(0, len(samples) * target // rate) * (rate / target)
    return np.interp(positions, np.arange(len(samples)), samples)


def add_noise(audio: Audio, snr_db: float, seed: int = 0, colour: str = "white") -> Audio:
    """Noise at a signal-to-noise ratio (speech power over noise power, where there is speech): "white" (flat, a
    hiss) or "brown" (power falling 6 dB an octave, a rumble: a fan, traffic, a motor)."""
    signal = audio.samples.astype(np.float64)
    voiced = signal[np.abs(signal) > 0.02 * np.abs(signal).max()] if len(signal) else signal
    power = float(np.mean(voiced**2)) if len(voiced) else 0.0
    rng = np.random.default_rng(seed)
    if colour == "white":
        noise = rng.normal(0.0, 1.0, len(signal))
    elif colour == "brown":
        noise = _brown(rng.normal(0.0, 1.0, len(signal)))
    else:
        raise ValueError(f"unknown noise colour {colour!r} (white, brown)")
    if len(noise):
        noise *= np.sqrt(power / 10 ** (snr_db / 10) / max(float(np.mean(noise**2)), 1e-12))
    return Audio(np.clip(np.round(signal + noise), -32768, 32767).astype(np.int16))


def _brown(white: np.ndarray) -> np.ndarray:
    """White noise shaped to 1/f^2 power (amplitude 1/f), flat below 20 Hz so it has no drift."""
    frequencies = np.fft.rfftfreq(len(white), 1.0 / RATE)
    return np.fft.irfft(np.fft.rfft(white) / np.maximum(frequencies, 20.0), len(white))
