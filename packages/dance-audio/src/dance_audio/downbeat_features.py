"""The input of madmom's downbeat RNN, computed with NumPy: 314 values per frame at 100 fps, 44.1 kHz.

For frame sizes 1024, 2048 and 4096 (3, 6 and 12 bands per octave): frames centred at sample
``int(i * 441)`` (zero padded), a symmetric Hann window, the STFT magnitude without the Nyquist
bin, a logarithmic triangular filterbank (30 Hz - 17 kHz, A4 = 440 Hz, unique bins, each filter
of area 1), ``log10(1 + x)``, and the positive difference to the frame about a quarter window
earlier; the three (spectrogram, difference) pairs are stacked side by side.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import scipy.fft

RATE = 44100
FPS = 100
HOP = RATE / FPS
FRAME_SIZES = (1024, 2048, 4096)
BANDS_PER_OCTAVE = (3, 6, 12)
FMIN, FMAX, FREF = 30.0, 17000.0, 440.0
CHUNK = 1024


def log_spaced(bands_per_octave: int, fmin: float, fmax: float, fref: float) -> np.ndarray:
    """Frequencies ``fref * 2**(k / bands_per_octave)`` within [fmin, fmax]."""
    lo = np.floor(np.log2(fmin / fref) * bands_per_octave)
    hi = np.ceil(np.log2(fmax / fref) * bands_per_octave)
    freqs = fref * 2.0 ** (np.arange(lo, hi) / bands_per_octave)
    return freqs[(freqs >= fmin) & (freqs <= fmax)]


def nearest_bins(freqs: np.ndarray, bin_freqs: np.ndarray) -> np.ndarray:
    """Index of the FFT bin nearest each frequency (ties go to the lower bin), without duplicates."""
    idx = np.clip(np.searchsorted(bin_freqs, freqs), 1, len(bin_freqs) - 1)
    lower_closer = freqs - bin_freqs[idx - 1] < bin_freqs[idx] - freqs
    return np.unique(idx - lower_closer)


@cache
def triangular_filterbank(frame_size: int, bands_per_octave: int) -> np.ndarray:
    """``(frame_size // 2, bands)`` triangular filters, each summing to 1."""
    n_bins = frame_size // 2
    bin_freqs = np.fft.fftfreq(frame_size, 1.0 / RATE)[:n_bins]
    centres = nearest_bins(log_spaced(bands_per_octave, FMIN, FMAX, FREF), bin_freqs)
    bank = np.zeros((n_bins, len(centres) - 2), dtype=np.float32)
    for band, (start, centre, stop) in enumerate(zip(centres[:-2], centres[1:-1], centres[2:], strict=True)):
        if stop - start < 2:  # too narrow for a triangle: a single bin
            centre, stop = start, start + 1
        rise = np.arange(centre - start) / max(centre - start, 1)
        fall = 1.0 - np.arange(stop - centre) / (stop - centre)
        tri = np.concatenate([rise, fall])
        bank[start:stop, band] = tri / tri.sum()
    return bank


def diff_frames(frame_size: int) -> int:
    """Frames back to the one where the Hann window first exceeds half its peak (at least 1)."""
    window = np.hanning(frame_size)
    first = int(np.argmax(window > 0.5 * window.max()))
    return int(max(1, round((frame_size / 2 - first) / HOP)))


def _filtered_magnitudes(y: np.ndarray, frame_size: int, bank: np.ndarray, n_frames: int) -> np.ndarray:
    """``(n_frames, bands)``: each frame's STFT magnitude (without the Nyquist bin) through ``bank``,
    a chunk of frames at a time (a 20-minute song never holds its full spectrogram)."""
    half = frame_size // 2
    padded = np.pad(y.astype(np.float32), (half, half + frame_size))
    hop = int(HOP)  # 441 samples exactly, so frame i starts at int(i * hop) - half (+ half padding)
    frames = np.lib.stride_tricks.sliding_window_view(padded, frame_size)[::hop][:n_frames]
    window = np.hanning(frame_size).astype(np.float32)
    out = np.empty((n_frames, bank.shape[1]), dtype=np.float32)
    for lo in range(0, n_frames, CHUNK):
        spectrum = scipy.fft.rfft(frames[lo : lo + CHUNK] * window, axis=1, workers=-1)
        out[lo : lo + CHUNK] = np.abs(spectrum[:, :half]) @ bank
    return out


def downbeat_input(y: np.ndarray) -> np.ndarray:
    """``(ceil(len(y) / 441), 314)`` float32 network input for mono samples at 44.1 kHz."""
    n_frames = int(np.ceil(len(y) / HOP))
    parts = []
    for frame_size, bands in zip(FRAME_SIZES, BANDS_PER_OCTAVE, strict=True):
        bank = triangular_filterbank(frame_size, bands)
        spec = np.log10(_filtered_magnitudes(y, frame_size, bank, n_frames) + 1.0)
        lag = diff_frames(frame_size)
        diff = np.zeros_like(spec)
        diff[lag:] = np.maximum(spec[lag:] - spec[:-lag], 0.0)
        parts += [spec, diff]
    return np.concatenate(parts, axis=1)
