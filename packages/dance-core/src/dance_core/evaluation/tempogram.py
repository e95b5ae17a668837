"""Autocorrelation tempograms of novelty curves (music onsets, kinematic beat impulses)."""

from __future__ import annotations

import numpy as np


def impulses(times: np.ndarray, n_frames: int, fps: float, weights: np.ndarray | None = None) -> np.ndarray:
    """A novelty curve with (weighted) unit impulses at event times."""
    curve = np.zeros(n_frames)
    idx = np.round(np.asarray(times) * fps).astype(np.int64)
    ok = (idx >= 0) & (idx < n_frames)
    np.add.at(curve, idx[ok], 1.0 if weights is None else np.asarray(weights)[ok])
    return curve


def tempogram(
    novelty: np.ndarray,
    fps: float,
    window_seconds: float = 6.0,
    hop_seconds: float = 0.5,
    bpm_range: tuple[float, float] = (40.0, 240.0),
    n_bpm: int = 100,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(tempogram (n_bpm, n_windows), bpm axis, window centre times)``.

    Each column is the normalized autocorrelation of a Hann-windowed stretch of the novelty
    curve, read at the lags of ``n_bpm`` log-spaced tempi.
    """
    win = max(4, int(round(window_seconds * fps)))
    hop = max(1, int(round(hop_seconds * fps)))
    half = win // 2  # zero padding so that window centres run from the start to the end
    x = np.concatenate([np.zeros(half), np.asarray(novelty, dtype=np.float64), np.zeros(win - half)])
    bpm = np.geomspace(bpm_range[0], bpm_range[1], n_bpm)
    lags = 60.0 * fps / bpm
    starts = np.arange(0, len(x) - win + 1, hop)
    out = np.zeros((n_bpm, len(starts)))
    taper = np.hanning(win)
    for k, s in enumerate(starts):
        seg = x[s : s + win]
        seg = (seg - seg.mean()) * taper[: len(seg)]
        ac = np.correlate(seg, seg, mode="full")[len(seg) - 1 :]
        if ac[0] <= 0:
            continue
        ac = ac / ac[0]
        out[:, k] = np.interp(lags, np.arange(len(ac)), ac, right=0.0)
    return np.clip(out, 0.0, None), bpm, (starts + win / 2 - half) / fps
