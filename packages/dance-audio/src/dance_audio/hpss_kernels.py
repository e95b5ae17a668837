"""numba kernels for harmonic-percussive separation, compiled once and cached: an exact running
median down the columns of an array, and the two soft masks from the median-filtered spectrograms."""

from __future__ import annotations

import numpy as np

from .numba_cache import use_cache_dir
from .stft import TINY32

use_cache_dir()  # before numba's first import, so the compiled kernels land in dance's cache

import numba  # noqa: E402


@numba.njit(cache=True, nogil=True)
def _median_columns(x, half, out, window, below, empty):  # pragma: no cover - compiled
    """Write to ``out`` the median of rows ``t - half .. t + half`` of ``x`` (reflected at both ends).

    ``window (2 half + 1, m)`` starts filled with +inf and holds each column's window in ascending
    order; ``below (m,)`` is scratch; ``empty (m,)`` is +inf, the value "removed" while filling.
    Removing ``old`` and inserting ``new`` maps sorted ``w`` to sorted ``w'`` position by position:
    ``u[r] = w[r] if w[r] < old else w[r + 1]`` is ``w`` without ``old``, and
    ``w'[r] = u[r] if u[r] < new else max(u[r - 1], new)`` puts ``new`` into ``u``; both are
    branch-free, so the loop over columns vectorises.
    """
    n = x.shape[0]
    size = 2 * half + 1
    for step in range(n + 2 * half):
        i = (step - half) % (2 * n)  # the row entering, reflected ("d c b a | a b c d | d c b a")
        if i >= n:
            i = 2 * n - 1 - i
        new = x[i]
        old = empty
        if step >= size:
            j = (step - size - half) % (2 * n)  # the row leaving
            if j >= n:
                j = 2 * n - 1 - j
            old = x[j]
        for c in range(len(below)):
            below[c] = -np.inf
        for r in range(size - 1):
            cur = window[r]
            nxt = window[r + 1]
            for c in range(len(cur)):
                u = cur[c] if cur[c] < old[c] else nxt[c]
                cur[c] = u if u < new[c] else max(below[c], new[c])
                below[c] = u
        last = window[size - 1]
        for c in range(len(last)):
            last[c] = max(below[c], new[c])
        if step >= size - 1:
            dst = out[step - size + 1]
            mid = window[half]
            for c in range(len(dst)):
                dst[c] = mid[c]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _soft_mask(x, ref, out, tiny):  # pragma: no cover - compiled
    """``out = x**2 / (x**2 + ref**2)`` in float32, both scaled by ``max(x, ref)`` first as librosa
    does (so the bits match); 0.5 where ``max(x, ref) < tiny``. Branch-free, so it vectorises."""
    half = np.float32(0.5)
    for t in range(x.shape[0]):
        x_row = x[t]
        ref_row = ref[t]
        out_row = out[t]
        for f in range(len(x_row)):
            z = max(x_row[f], ref_row[f])
            a = x_row[f] / z
            a = a * a
            b = ref_row[f] / z
            b = b * b
            out_row[f] = half if z < tiny else a / (a + b)


def running_median(x: np.ndarray, size: int) -> np.ndarray:
    """Median over a window of ``size`` (odd) rows centred on each row, per column, float32.

    Rows past either end are mirrored (scipy.ndimage's ``reflect``: ``d c b a | a b c d``), so the
    result equals ``scipy.ndimage.median_filter(x, size=(size, 1), mode="reflect")`` exactly.
    """
    if size % 2 != 1:
        raise ValueError(f"running_median: size must be odd, got {size}")
    x = np.ascontiguousarray(x, dtype=np.float32)
    n, m = x.shape
    out = np.empty_like(x)
    if n == 0 or m == 0:
        return out
    window = np.full((size, m), np.inf, dtype=np.float32)
    _median_columns(x, size // 2, out, window, np.empty(m, np.float32), np.full(m, np.inf, np.float32))
    return out


def soft_mask(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """The power-2 soft mask of 2-D ``x`` against ``ref`` (same shape), float32: ``x**2 / (x**2 + ref**2)``,
    0.5 where both are ~0; bit for bit librosa's ``util.softmask(x, ref, power=2, split_zeros=True)``."""
    x = np.ascontiguousarray(x, dtype=np.float32)
    ref = np.ascontiguousarray(ref, dtype=np.float32)
    if x.shape != ref.shape or x.ndim != 2:
        raise ValueError(f"soft_mask: shapes {x.shape} and {ref.shape} are not one 2-D shape")
    out = np.empty_like(x)
    _soft_mask(x, ref, out, TINY32)
    return out
