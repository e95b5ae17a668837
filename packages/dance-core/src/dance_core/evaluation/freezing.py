"""TM2D's freezing scores: the percentage of frozen frames (PFF) and its area under the curve (AUC_f).

A frame is frozen when the largest joint speed stays at or below a threshold (0.015 m/s in TM2D) for a
run of at least ``min_seconds`` (3 s). PFF is the percentage of frozen frames. AUC_f integrates
PFF over thresholds from 0 to 0.03 m/s and divides by that range, so it reads as the mean PFF (%)
over the thresholds: 100 for a clip that never moves, 0 for one that never slows down.
"""

from __future__ import annotations

import numpy as np

from dance_core.evaluation.clips import joint_speeds


def max_joint_speed(positions: np.ndarray, fps: float) -> np.ndarray:
    """The largest joint speed of every frame, ``(T,)`` in units/s."""
    return joint_speeds(positions, fps).max(axis=1)


def frozen_mask(speed: np.ndarray, fps: float, threshold: float, min_seconds: float) -> np.ndarray:
    """Frames inside runs where ``speed <= threshold`` that last at least ``min_seconds``.

    (``<=`` so that at threshold 0 a perfectly still stretch still counts as frozen.)
    """
    slow = np.asarray(speed) <= threshold
    mask = np.zeros(len(slow), dtype=bool)
    min_frames = int(np.ceil(min_seconds * fps - 1e-9))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], slow.astype(np.int8), [0]])))
    for start, end in zip(edges[::2], edges[1::2], strict=True):
        if end - start >= min_frames:
            mask[start:end] = True
    return mask


def pff_curve(speed: np.ndarray, fps: float, thresholds: np.ndarray, min_seconds: float) -> np.ndarray:
    """PFF (%) at each threshold."""
    return np.array([100.0 * frozen_mask(speed, fps, t, min_seconds).mean() for t in thresholds])


def auc(thresholds: np.ndarray, curve: np.ndarray) -> float:
    """Trapezoidal area under ``curve`` divided by the threshold range (a mean value)."""
    span = thresholds[-1] - thresholds[0]
    if span <= 0:
        return float(curve[0])
    return float(((curve[1:] + curve[:-1]) / 2 * np.diff(thresholds)).sum() / span)
