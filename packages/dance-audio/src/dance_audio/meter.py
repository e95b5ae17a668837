"""The meter of a song from its tracked beats: how many beats make a bar (3 for a waltz, 4 otherwise).

Each beat's *rhythm pattern* is the onset envelope sampled at ``STEPS`` points across the beat (log
compressed): the drums, strums and notes the beat holds and where inside it they fall. A bar's beats
differ from each other (the kick on one, the snare on two...) and the pattern repeats bar after bar, so
the patterns of beats a bar apart are alike: for a meter of ``m`` beats, the mean correlation of
patterns ``m`` and ``2 m`` beats apart is high, and for the wrong meter one of the two lags falls
between bars. Four is the default: three is chosen only when its score beats four's by ``MARGIN``
(on music without a repeating bar, the two tie and a dancer counts in fours).

When the tracker hears a fast waltz in dotted half-bars (two pulses a bar), the bars it hears have two
of its beats and the meter found is four, which is what a dancer following those beats counts.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

STEPS = 12  # samples of the onset envelope per beat
MARGIN = 0.03  # how much better three must score than four


def beat_patterns(envelope: np.ndarray, times: np.ndarray, fps: float, steps: int = STEPS) -> np.ndarray:
    """``(beats - 1, steps)``: the onset envelope (at ``fps``) across each beat interval, log compressed
    by its median."""
    env = np.asarray(envelope, np.float64)
    times = np.asarray(times, np.float64)
    if len(times) < 2 or len(env) == 0:
        return np.zeros((0, steps))
    at = (times[:-1, None] + (times[1:] - times[:-1])[:, None] * np.arange(steps)[None] / steps) * fps
    patterns = np.interp(at, np.arange(len(env)), env)
    return np.log1p(patterns / (np.median(patterns) + 1e-9))


def lag_similarity(patterns: np.ndarray, lag: int) -> float:
    """Mean correlation of the patterns of beats ``lag`` apart (NaN when there are too few)."""
    if len(patterns) <= lag:
        return float("nan")
    a, b = patterns[:-lag], patterns[lag:]
    a = a - a.mean(1, keepdims=True)
    b = b - b.mean(1, keepdims=True)
    den = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    return float(np.mean((a * b).sum(1) / np.maximum(den, 1e-12)))


def meter_scores(envelope: np.ndarray, times: np.ndarray, fps: float, candidates: Sequence[int]) -> dict[int, float]:
    """Per candidate meter ``m``, the mean similarity of beats ``m`` and ``2 m`` apart."""
    patterns = beat_patterns(envelope, times, fps)
    return {m: float(np.nanmean([lag_similarity(patterns, m), lag_similarity(patterns, 2 * m)]))
            if len(patterns) > m else float("nan") for m in candidates}


def detect_meter(envelope: np.ndarray, times: np.ndarray, fps: float, candidates: Sequence[int] = (3, 4),
                 margin: float = MARGIN) -> int:
    """Beats per bar among ``candidates``: the largest candidate (four by default) unless another one's
    score beats it by ``margin``; the largest when the song is too short to tell."""
    candidates = sorted(set(int(c) for c in candidates))
    default = candidates[-1]
    if len(candidates) == 1:
        return default
    scores = meter_scores(envelope, times, fps, candidates)
    best = max((m for m in candidates if np.isfinite(scores[m])), key=lambda m: scores[m], default=default)
    if best != default and np.isfinite(scores[default]) and scores[best] < scores[default] + margin:
        return default
    return best
