"""Tuning estimation: how far (in fractions of a bin) a song's pitches sit from equal temperament at A440.

As ``librosa.estimate_tuning``: spectral peaks between 150 Hz and 4 kHz that exceed a tenth of
their frame's maximum are located by parabolic interpolation (``piptrack``); the louder half of
them vote in a histogram of their deviation from the nearest bin, and the histogram's peak wins.
"""

from __future__ import annotations

import numpy as np


def spectral_peaks(
    magnitude: np.ndarray, rate: float, n_fft: int, fmin: float = 150.0, fmax: float = 4000.0, threshold: float = 0.1
) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and magnitudes (float32) of the interpolated peaks of a ``(n_frames, n_bins)`` spectrogram.

    A peak is a bin in ``[fmin, fmax)`` that is a local maximum along frequency once bins at or
    below ``threshold`` times the frame's maximum are zeroed; its parabola through the neighbours
    gives the frequency shift and the magnitude correction. Same values as ``librosa.piptrack``.
    """
    mag = np.asarray(magnitude, dtype=np.float32)
    n_bins = mag.shape[1]
    freqs = np.linspace(0, float(rate) / 2, n_bins)
    band = np.flatnonzero((max(fmin, 0.0) <= freqs) & (freqs < min(fmax, float(rate) / 2)))
    band = band[(band > 0) & (band < n_bins - 1)]  # never the end bins: fmax < rate / 2, and bin 0 is no peak
    if len(band) == 0:
        return np.zeros(0, np.float32), np.zeros(0, np.float32)
    lo, hi = int(band[0]), int(band[-1]) + 1
    # a local maximum of the thresholded spectrum is a bin above the threshold that beats its
    # left neighbour and is not beaten by its right one (thresholded neighbours only lose)
    centre, left, right = mag[:, lo:hi], mag[:, lo - 1 : hi - 1], mag[:, lo + 1 : hi + 1]
    floor = threshold * mag.max(axis=1, keepdims=True)
    frames, bins = np.nonzero((centre > floor) & (centre > left) & (centre >= right))
    bins += lo
    at, below, above = mag[frames, bins], mag[frames, bins - 1], mag[frames, bins + 1]
    shift = _parabola_shift(below, at, above)
    slope = (above - below) / np.float32(2.0)
    pitches = ((bins + shift) * float(rate) / n_fft).astype(np.float32)
    return pitches, at + np.float32(0.5) * slope * shift


def _parabola_shift(below: np.ndarray, at: np.ndarray, above: np.ndarray) -> np.ndarray:
    """Offset (in bins, float32) of the vertex of the parabola through three neighbouring values;
    0 where it would fall more than a bin away."""
    curvature = (above + below).astype(np.float64) - 2.0 * at.astype(np.float64)
    half_diff = (above - below).astype(np.float64) / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        shift = -half_diff / curvature
    shift[np.abs(half_diff) >= np.abs(curvature)] = 0.0
    return shift.astype(np.float32)


def pitch_tuning(frequencies: np.ndarray, resolution: float = 0.01, bins_per_octave: int = 12) -> float:
    """The most common deviation of ``frequencies`` from the equal-tempered grid (A440), in
    ``[-0.5, 0.5)`` bins, at ``resolution``; 0 when there are no positive frequencies."""
    freqs = np.atleast_1d(frequencies)
    freqs = freqs[freqs > 0]
    if len(freqs) == 0:
        return 0.0
    residual = np.mod(bins_per_octave * np.log2(freqs / (440.0 / 16)), 1.0)
    residual[residual >= 0.5] -= 1.0
    edges = np.linspace(-0.5, 0.5, int(np.ceil(1.0 / resolution)) + 1)
    counts, _ = np.histogram(residual, edges)
    return float(edges[np.argmax(counts)])


def estimate_tuning(
    magnitude: np.ndarray, rate: float, n_fft: int, bins_per_octave: int = 12, resolution: float = 0.01
) -> float:
    """Tuning of a ``(n_frames, n_bins)`` magnitude spectrogram, from its peaks at or above the
    median peak magnitude (``librosa.estimate_tuning`` on the same spectrogram)."""
    pitches, mags = spectral_peaks(magnitude, rate, n_fft)
    if len(pitches) == 0:
        return 0.0
    loud = pitches[(mags >= np.median(mags)) & (pitches > 0)]
    return pitch_tuning(loud, resolution=resolution, bins_per_octave=bins_per_octave)
