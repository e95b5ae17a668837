"""Resampling and frame-grid helpers shared by the extractors (one alignment rule for all)."""

from __future__ import annotations

import numpy as np


def resample(samples: np.ndarray, rate: int, target: int) -> np.ndarray:
    """Band-limited resampling with soxr's high-quality filter (no-op when the rates match)."""
    if int(rate) == int(target):
        return np.ascontiguousarray(samples, dtype=np.float32)
    import soxr

    return soxr.resample(np.asarray(samples, np.float32), int(rate), int(target), quality="HQ")


def fit_frames(x: np.ndarray, n_frames: int) -> np.ndarray:
    """Crop or edge-pad a ``(T, D)`` array to ``n_frames`` rows (frame i stays at time i / fps)."""
    if len(x) >= n_frames:
        return x[:n_frames]
    if len(x) == 0:
        return np.zeros((n_frames, x.shape[1]), dtype=x.dtype)
    return np.concatenate([x, np.repeat(x[-1:], n_frames - len(x), axis=0)], axis=0)


def retime(x: np.ndarray, src_fps: float, n_frames: int, fps: float) -> np.ndarray:
    """Linearly interpolate a ``(T, D)`` sequence sampled at ``i / src_fps`` to times ``i / fps``.

    Times past the last source frame hold its value. Interpolating at the target times (rather than
    pretending the rates match, or taking every k-th frame) keeps events at the right time.
    """
    x = np.asarray(x, dtype=np.float64)
    if len(x) == 0:
        return np.zeros((n_frames, x.shape[1]), dtype=np.float32)
    pos = np.arange(n_frames) * (src_fps / fps)
    lo = np.clip(np.floor(pos).astype(np.int64), 0, len(x) - 1)
    hi = np.minimum(lo + 1, len(x) - 1)
    w = np.clip(pos - lo, 0.0, 1.0)[:, None]
    return ((1.0 - w) * x[lo] + w * x[hi]).astype(np.float32)


def events_to_onehot(times: np.ndarray, n_frames: int, fps: float) -> np.ndarray:
    """A ``(n_frames,)`` array with 1 at the frame nearest each event time (events past the end dropped)."""
    out = np.zeros(n_frames, dtype=np.float32)
    idx = np.round(np.asarray(times, dtype=np.float64) * fps).astype(np.int64)
    out[idx[(idx >= 0) & (idx < n_frames)]] = 1.0
    return out


def event_phase(times: np.ndarray, n_frames: int, fps: float) -> np.ndarray:
    """Phase in [0, 1) of each frame between consecutive events, extrapolated at the ends.

    Before the first event and after the last one the mean inter-event interval continues the grid;
    with fewer than two events the phase is 0 everywhere.
    """
    times = np.sort(np.asarray(times, dtype=np.float64))
    t = np.arange(n_frames) / fps
    if len(times) < 2:
        return np.zeros(n_frames, dtype=np.float32)
    period = float(np.mean(np.diff(times)))
    grid = np.concatenate(
        [
            times[0] - period * np.arange(int(np.ceil(times[0] / period)) + 1, 0, -1),
            times,
            times[-1] + period * np.arange(1, int(np.ceil((t[-1] - times[-1]) / period)) + 2),
        ]
    )
    k = np.clip(np.searchsorted(grid, t, side="right") - 1, 0, len(grid) - 2)
    phase = (t - grid[k]) / (grid[k + 1] - grid[k])
    return np.clip(phase, 0.0, np.nextafter(1.0, 0.0)).astype(np.float32)
