"""``dance evaluate``'s realism metrics: window statistics against the reference dances, and beat
locking from the body's own accents (the measures of :mod:`dance_core.evaluation.realism`).

``realism`` is read against its own scale, the distance between the first and the second halves of
the reference clips: a generated set as close to the reference as one half of real dance is to the
other scores a ratio of 1. ``body-locking`` gives no beats to a figure that only translates, bobs or
turns rigidly, so a metronome cannot pass it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.evaluation.clips import check_positions, require_clips
from dance_core.evaluation.metrics import with_music
from dance_core.evaluation.realism import STATISTICS, WINDOW, body_locking, realism_distance, window_statistics
from dance_core.protocols import JointClip, MetricResult

#: windows each side needs for a covariance of the statistics worth a distance (twice their number)
MIN_WINDOWS = 2 * len(STATISTICS)


def _names(clip: JointClip, what: str) -> list[str]:
    if not clip.joints:
        raise DataError(f"{what}: {clip.name}: the clip has no joint names (realism maps joints by name)")
    return list(clip.joints)


def clip_windows(clip: JointClip, hop: float, what: str, part: slice = slice(None)) -> np.ndarray:
    """The window statistics of a clip (or a ``part`` of its frames)."""
    p = check_positions(clip)[part]
    return window_statistics(p, clip.fps, _names(clip, what), hop=hop, where=clip.name)


class Realism:
    """Fréchet distance of window statistics to the reference, its scale and the statistics in range."""

    needs = ("reference",)

    def __init__(self, hop: float = 0.5):
        self.hop = hop

    def _windows(self, clips: Sequence[JointClip], notes: list[str], role: str,
                 part: slice = slice(None)) -> np.ndarray:
        rows = []
        for clip in clips:
            w = clip_windows(clip, self.hop, "realism", part)
            if len(w) == 0:
                notes.append(f"realism: {role} {clip.name}: shorter than one window; skipped")
            rows.append(w)
        return np.concatenate(rows) if rows else np.zeros((0, len(STATISTICS)))

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """``realism`` (distance), ``realism_in_range`` (statistics whose generated median lies inside the
        reference's 10-90 %), and when the reference is long enough ``realism_scale`` (its halves) and
        ``realism_ratio``."""
        require_clips(generated, 1, "realism")
        require_clips(reference, 1, "realism", "reference")
        notes: list[str] = []
        gen = self._windows(generated, notes, "generated")
        ref = self._windows(reference, notes, "reference")
        if len(gen) < 2 or len(ref) < 2:
            raise DataError(f"realism: needs at least 2 windows of {WINDOW:g} s on each side ({len(gen)} generated, "
                            f"{len(ref)} reference)")
        first = np.concatenate([clip_windows(c, self.hop, "realism", slice(0, len(c.positions) // 2))
                                for c in reference])
        second = np.concatenate([clip_windows(c, self.hop, "realism", slice(len(c.positions) // 2, None))
                                 for c in reference])
        distance = realism_distance(gen, ref)
        if min(len(gen), len(ref)) < MIN_WINDOWS:
            notes.append(f"realism: {len(gen)} generated and {len(ref)} reference windows; below {MIN_WINDOWS} a side "
                         "the distance is unstable (longer or more clips)")
        scale = float("nan")
        if min(len(first), len(second)) >= MIN_WINDOWS:
            scale = realism_distance(first, second)
        else:
            notes.append(f"realism: the reference's halves give {len(first)} and {len(second)} windows, fewer than "
                         f"{MIN_WINDOWS}: no scale (realism_ratio n/a)")
        lo, hi = np.percentile(ref, 10, axis=0), np.percentile(ref, 90, axis=0)
        median = np.median(gen, axis=0)
        tol = 1e-9 * (1.0 + np.abs(hi))  # rounding noise of a statistic that is constant in the reference
        inside = (median >= lo - tol) & (median <= hi + tol)
        for name, m, a, b, ok in zip(STATISTICS, median, lo, hi, inside, strict=True):
            if not ok:
                notes.append(f"realism: {name} median {m:.3g} outside the reference's 10-90 % ({a:.3g}-{b:.3g})")
        per_clip = {}
        for clip in generated:
            w = clip_windows(clip, self.hop, "realism")
            if len(w) >= 2:
                per_clip[clip.name] = {"realism": realism_distance(w, ref)}
        values = {"realism": distance, "realism_in_range": float(inside.sum())}
        if np.isfinite(scale):  # a metric's values are finite: without a scale (noted above) there is no ratio
            values |= {"realism_scale": scale, "realism_ratio": distance / scale}
        return MetricResult(values, per_clip, notes)


class BodyLocking:
    """Beat locking of the body's own accents, its wrong-tempo control and accents per beat (means)."""

    needs = ("music",)

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """``body_locking`` (1 on the beat, -1 off it, ~0 unrelated), ``body_locking_control`` and
        ``accents_per_beat``; clips with fewer than 4 accents inside the beats are skipped with a note."""
        usable, notes = with_music(generated, "body locking")
        per_clip = {}
        for clip, p, music in usable:
            s = body_locking(p, clip.fps, _names(clip, "body locking"), music, clip.name)
            if not np.isfinite(s["locking"]):
                notes.append(f"body locking: {clip.name}: fewer than 4 accents of its own between the beats "
                             "(a still or rigid figure); skipped")
                continue
            per_clip[clip.name] = {"body_locking": s["locking"], "body_locking_control": s["control"],
                                   "accents_per_beat": s["accents_per_beat"]}
        if not per_clip:
            raise DataError("body locking: no clip has accents of its own between the music's beats")
        keys = ("body_locking", "body_locking_control", "accents_per_beat")
        return MetricResult({k: float(np.mean([v[k] for v in per_clip.values()])) for k in keys}, per_clip, notes)


def build_realism(config: Any, **_: Any) -> Realism:
    """``realism``."""
    return Realism(config.hop_seconds)


def build_body_locking(config: Any, **_: Any) -> BodyLocking:
    """``body-locking``."""
    return BodyLocking()
