"""Mel-frequency cepstral coefficients and their deltas, as ``librosa.feature.mfcc`` and ``delta``."""

from __future__ import annotations

import numpy as np
import scipy.fft


def mfcc(db: np.ndarray, n_mfcc: int = 20) -> np.ndarray:
    """``(n_frames, n_mfcc)`` float32 cepstra of a ``(n_frames, n_mels)`` dB mel spectrogram: its
    orthonormal DCT-II over mel bands, first ``n_mfcc`` coefficients (librosa's ``mfcc(S=db)``)."""
    return scipy.fft.dct(np.asarray(db, dtype=np.float32), type=2, norm="ortho", axis=1)[:, :n_mfcc]


def delta(x: np.ndarray, width: int = 3) -> np.ndarray:
    """First derivative along axis 0 (frames): the least-squares slope over ``width`` (odd) frames.

    The first and last ``width // 2`` frames take the slope of the first and last full window, as
    ``scipy.signal.savgol_filter(polyorder=1, deriv=1, mode="interp")`` (librosa's ``delta``) does.
    """
    if width < 3 or width % 2 != 1:
        raise ValueError(f"delta: width must be an odd integer >= 3, got {width}")
    if len(x) < width:
        raise ValueError(f"delta: {len(x)} frames are fewer than width={width}")
    half = width // 2
    offsets = np.arange(-half, half + 1)
    weights = offsets / float(np.sum(offsets**2))
    n = len(x)
    out = np.zeros(x.shape, dtype=np.float64)
    for w, k in zip(weights, offsets, strict=True):
        if k:
            out[half : n - half] += w * x[half + k : n - half + k]
    out[:half] = out[half]
    out[n - half :] = out[n - half - 1]
    return out.astype(x.dtype)
