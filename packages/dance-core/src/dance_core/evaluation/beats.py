"""Motion ("kinematic") beat detectors and the scores that compare them with music beats.

All times are in seconds, so every detector and score works at any frame rate; the defaults
turn the reference implementations' frame counts at 60 fps into seconds.

- Bailando: motion beats are local minima of the mean joint speed smoothed with a Gaussian of
  5 frames (5/60 s); the score is the mean over music beats of ``exp(-d^2 / 2 sigma^2)`` with
  ``d`` the distance to the nearest motion beat and ``sigma`` = 3 frames (3/60 s).
- FACT (mint): motion beats are local minima, over +-10 frames (10/60 s), of the *summed* joint
  speed, unsmoothed; the score is the same Gaussian but averaged over *motion* beats (0 when the
  motion has no beats).
- Transflower: kinematic beats are local minima of the hips' vertical velocity (the moments of
  fastest downward motion); the beat offset of a music beat is the time to the nearest one.
- DanceRevolution: beat coverage ``B_k / B_m`` and hit rate ``B_a / B_k``, with ``B_a`` the
  kinematic beats within a tolerance of a music beat (the paper leaves the detector and tolerance
  unspecified; we use Bailando's detector and 0.1 s, see ``BeatCoverageConfig``).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import argrelextrema


def local_minima(x: np.ndarray, order: int = 1) -> np.ndarray:
    """Indices ``i`` where ``x[i]`` is strictly below every value within ``order`` frames."""
    if len(x) < 3:
        return np.zeros(0, dtype=np.int64)
    return argrelextrema(np.asarray(x, dtype=np.float64), np.less, order=max(1, int(order)))[0]


def mean_joint_speed(positions: np.ndarray) -> np.ndarray:
    """Mean over joints of the per-frame displacement norm, ``(T-1,)`` (frame t to t+1)."""
    return np.linalg.norm(np.diff(positions, axis=0), axis=-1).mean(axis=1)


def bailando_motion_beats(positions: np.ndarray, fps: float, smooth_seconds: float = 5 / 60) -> np.ndarray:
    """Times of the local minima of the Gaussian-smoothed mean joint speed."""
    speed = mean_joint_speed(positions)
    sigma = smooth_seconds * fps
    if sigma > 0:
        speed = gaussian_filter1d(speed, sigma)
    return local_minima(speed) / fps


def fact_motion_beats(positions: np.ndarray, fps: float, order_seconds: float = 10 / 60) -> np.ndarray:
    """Times of the local minima (over +-``order_seconds``) of the summed joint speed."""
    speed = np.zeros(len(positions))
    speed[1:] = np.linalg.norm(np.diff(positions, axis=0), axis=-1).sum(axis=1)
    return local_minima(speed, int(round(order_seconds * fps))) / fps


def hips_vertical_velocity(positions: np.ndarray, fps: float, hips: int = 0, smooth_seconds: float = 0.0) -> np.ndarray:
    """The hips joint's vertical (Y) velocity per frame, ``(T,)`` in units/s (central differences)."""
    v = np.gradient(positions[:, hips, 1]) * fps
    sigma = smooth_seconds * fps
    return gaussian_filter1d(v, sigma) if sigma > 0 else v


def hips_beats(positions: np.ndarray, fps: float, hips: int = 0, smooth_seconds: float = 0.0) -> np.ndarray:
    """Times of the local minima of the hips' vertical velocity where it moves downwards."""
    v = hips_vertical_velocity(positions, fps, hips, smooth_seconds)
    idx = local_minima(v)
    return idx[v[idx] < 0] / fps


def nearest_distances(targets: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """For every target time, the absolute time to the nearest candidate (``inf`` if none)."""
    targets = np.asarray(targets, dtype=np.float64)
    candidates = np.sort(np.asarray(candidates, dtype=np.float64))
    if len(candidates) == 0:
        return np.full(len(targets), np.inf)
    pos = np.searchsorted(candidates, targets)
    left = candidates[np.clip(pos - 1, 0, len(candidates) - 1)]
    right = candidates[np.clip(pos, 0, len(candidates) - 1)]
    return np.minimum(np.abs(targets - left), np.abs(targets - right))


def bailando_score(music_beats: np.ndarray, motion_beats: np.ndarray, sigma: float = 3 / 60) -> float:
    """Mean over music beats of ``exp(-d^2 / 2 sigma^2)`` (0 for motion without beats)."""
    if len(music_beats) == 0:
        raise ValueError("no music beats")
    d = nearest_distances(music_beats, motion_beats)
    return float(np.exp(-(d**2) / (2 * sigma**2)).mean())


def fact_score(music_beats: np.ndarray, motion_beats: np.ndarray, sigma: float = 3 / 60) -> float:
    """Mean over motion beats of ``exp(-d^2 / 2 sigma^2)``; 0 when there is no motion beat."""
    if len(music_beats) == 0:
        raise ValueError("no music beats")
    if len(motion_beats) == 0:
        return 0.0
    d = nearest_distances(motion_beats, music_beats)
    return float(np.exp(-(d**2) / (2 * sigma**2)).mean())


def coverage_and_hit_rate(
    music_beats: np.ndarray, kinematic_beats: np.ndarray, tolerance: float
) -> tuple[float, float]:
    """DanceRevolution's beat coverage ``B_k / B_m`` and hit rate ``B_a / B_k`` (as fractions)."""
    if len(music_beats) == 0:
        raise ValueError("no music beats")
    coverage = len(kinematic_beats) / len(music_beats)
    if len(kinematic_beats) == 0:
        return coverage, 0.0
    aligned = nearest_distances(kinematic_beats, music_beats) <= tolerance + 1e-9
    return coverage, float(aligned.mean())


def beats_within(beats: np.ndarray | None, duration: float) -> np.ndarray:
    """The beats inside ``[0, duration)`` (an empty array for None)."""
    if beats is None:
        return np.zeros(0)
    b = np.asarray(beats, dtype=np.float64)
    return b[(b >= 0) & (b < duration)]
