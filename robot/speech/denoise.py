"""Steady background noise taken out of an utterance before it is decoded: a Wiener filter per frequency bin,
with the noise spectrum estimated from the utterance's own quietest frames and the a-priori SNR decision-directed
(Ephraim and Malah's scheme, which keeps the "musical" residue of plain spectral subtraction low).

A fan, a motor's whine, the hiss of a cheap microphone: noise that stays put while a command is spoken.
"""

from __future__ import annotations

import numpy as np

FRAME = 512  # 32 ms at 16 kHz
HOP = FRAME // 4
QUIET_FRACTION = 0.15  # the quietest 15% of frames are taken as noise alone
SMOOTHING = 0.9  # decision-directed a-priori SNR: weight of the previous frame's clean estimate
# -8 dB: the most a bin is turned down. Over 30 commands x 4 voices at 10 dB SNR (word error, plan right):
# no filter 15.7 %, 86.7 %; floor 0.1 19.0 %, 84.2 %; 0.3 13.2 %, 87.5 %; 0.5 14.2 %, 89.2 %; 0.4 with smoothing
# 0.9 11.2 %, 91.7 % (0.98 and 0.7 did worse). Deeper cuts leave the speech too hollow for the decoder's models.
GAIN_FLOOR = 0.4


def snr_db(samples: np.ndarray) -> float:
    """How far speech stands above the steady noise: the loudest tenth of 32 ms frames over the quietest 15 %
    (inf for digital silence around the words)."""
    frames = len(samples) // FRAME
    if frames < 4:
        return float("inf")
    energy = np.sort((samples[: frames * FRAME].astype(np.float64).reshape(frames, FRAME) ** 2).mean(axis=1))
    quiet = energy[: max(1, int(frames * QUIET_FRACTION))].mean()
    loud = energy[-max(1, frames // 10) :].mean()
    return float("inf") if quiet < 1.0 else float(10 * np.log10(loud / quiet))


def denoise(samples: np.ndarray) -> np.ndarray:
    """int16 samples in, int16 samples out, the same length."""
    if len(samples) < 4 * FRAME:
        return samples
    signal = samples.astype(np.float64)
    window = np.hanning(FRAME + 1)[:-1]
    starts = np.arange(0, len(signal) - FRAME + 1, HOP)
    spectra = np.fft.rfft(np.stack([signal[s : s + FRAME] * window for s in starts]), axis=1)
    power = np.abs(spectra) ** 2
    energy = power.sum(axis=1)
    quiet = power[energy <= np.quantile(energy, QUIET_FRACTION)]
    noise = quiet.mean(axis=0) + 1e-9
    if not np.any(noise > 1e-6):  # digital silence around the words: nothing to remove
        return samples
    gains = np.empty_like(power)
    previous_clean = np.zeros(power.shape[1])
    for i, frame_power in enumerate(power):
        posterior = frame_power / noise
        prior = SMOOTHING * previous_clean / noise + (1 - SMOOTHING) * np.maximum(posterior - 1.0, 0.0)
        gain = np.maximum(prior / (1.0 + prior), GAIN_FLOOR)
        gains[i] = gain
        previous_clean = gain**2 * frame_power
    frames = np.fft.irfft(spectra * gains, n=FRAME, axis=1) * window
    out = np.zeros(len(signal))
    norm = np.zeros(len(signal))
    for start, frame in zip(starts, frames, strict=True):
        out[start : start + FRAME] += frame
        norm[start : start + FRAME] += window**2
    covered = norm > 1e-3
    out[covered] /= norm[covered]
    out[~covered] = signal[~covered] * GAIN_FLOOR
    return np.clip(np.round(out), -32768, 32767).astype(np.int16)
