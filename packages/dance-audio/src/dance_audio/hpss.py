"""Harmonic-percussive separation by median filtering (Fitzgerald 2010), as ``librosa.decompose.hpss``.

A magnitude spectrogram is median filtered across time (sustained, harmonic energy survives) and
across frequency (broadband, percussive energy survives), both at once on two threads, with a
31-bin window and rows reflected at the edges; power-2 soft masks then split each bin between the
two, 0.5 each where both are ~0 (librosa's defaults: ``kernel_size=31, power=2, margin=1``).
Spectrograms here are frames first, ``(n_frames, n_bins)``.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .hpss_kernels import running_median, soft_mask


def hpss_masks(
    magnitude: np.ndarray, kernel_size: int = 31, percussive: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """Harmonic and percussive soft masks (float32) of a ``(n_frames, n_bins)`` magnitude spectrogram.

    Equal, bit for bit, to ``librosa.decompose.hpss(S, kernel_size=kernel_size, mask=True)`` on the
    same magnitudes (transposed). With ``percussive=False`` only the harmonic mask is computed
    (the percussive one is ``1 -`` it, up to rounding) and ``None`` comes back in its place.
    """
    magnitude = np.asarray(magnitude, dtype=np.float32)
    with ThreadPoolExecutor(1) as pool:  # the kernels release the GIL: filter both ways at once
        across_time = pool.submit(running_median, magnitude, kernel_size)
        percussive_median = running_median(magnitude.T, kernel_size).T  # across frequency
        harmonic = across_time.result()
    return soft_mask(harmonic, percussive_median), soft_mask(percussive_median, harmonic) if percussive else None
