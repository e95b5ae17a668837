"""Move validity: is every bar of a dance one of the synthetic dancer's moves?

A detector, not a copy of the choreographer: it knows the moves only as the generator renders them
(:func:`dance_core.synth.dancer.render_moves`), never how the generator picks them. Templates:
every move of :data:`~dance_core.synth.dancer.MOVES`, one bar long, rendered on a grid of styles
spanning the generator's dancers (amplitude, groove depth, arm carriage, both lead sides, walking
speed, every timing: on or off the beat, smooth or sharp), at every place of the bar in the moves'
four-beat cycle. The moves are functions of musical time, so a bar sampled at ``SAMPLES`` points per
beat is the same at every tempo: one rendering in beat time serves every tempo.

A dance is cut into bars on the music's beats (``JointClip.music_beats``) or, without them, on its
own kinematic beats (the pelvis's lowest points, where the generator's groove puts every dancer
beat; a dance with none, a frozen one, on a nominal 120 bpm count); the meter and the downbeat are
unknown, so every meter of ``meters`` and every downbeat is tried and the cut whose bars lie nearest
to the templates is kept. Each bar is resampled to ``SAMPLES`` points per beat and every beat of it
is put in its own body frame (:func:`dance_core.evaluation.canon.canonicalize` at the beat's middle:
root over the origin, hips facing +Z), so neither where on the floor nor which way the dancer faces
counts, while travelling and turning within a beat do. A bar's distance is the RMS joint distance
(m) to the nearest template, or to two templates one after the other (the dancers change moves at
any beat, at most once a bar, blending over the half beat before: that half beat is not scored). A
bar is valid within ``threshold`` metres unless it is held still (moving less than half as much as
the stillest template, a bounce, which is itself only about 0.023 m from its mean pose).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache
from math import lcm
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.evaluation.beats import beats_within
from dance_core.evaluation.canon import SMPL_HIPS, canonicalize
from dance_core.evaluation.clips import check_positions, require_clips
from dance_core.evaluation.quality import hip_height_beats
from dance_core.protocols import JointClip, MetricResult

WHAT = "move validity"
#: samples per beat of a time-normalized bar
SAMPLES = 6
#: points of the style grid (the centres of as many equal cells between the dancers' lowest and highest
#: value) for the amplitude, groove depth and arm carriage
GRID = {"amplitude": 3, "groove": 1, "arms": 3}
#: the count of a dance with neither music beats nor kinematic beats
NOMINAL_BPM = 120.0


def style_grid() -> list[dict[str, float]]:
    """Template styles: a grid over the union of the dancers' style ranges, both lead sides, every
    dancer timing (delay, attack) and, for the walk, the lowest and highest walking speed."""
    from dance_core.synth.dancer import DANCERS

    profiles = list(DANCERS.values())
    axes = {}
    for k, n in GRID.items():
        lo, hi = min(getattr(p, k)[0] for p in profiles), max(getattr(p, k)[1] for p in profiles)
        axes[k] = lo + (hi - lo) * (np.arange(n) + 0.5) / n
    timings = sorted({(p.delay, p.attack) for p in profiles})
    speeds = (min(p.speed[0] for p in profiles), max(p.speed[1] for p in profiles))
    return [{"amplitude": a, "groove": g, "arms": r, "lead": lead, "speed": v, "delay": d, "attack": k}
            for a in axes["amplitude"] for g in axes["groove"] for r in axes["arms"] for lead in (-1.0, 1.0)
            for d, k in timings for v in speeds]


@lru_cache(maxsize=8)
def templates(meter: int) -> tuple[np.ndarray, tuple[str, ...]]:
    """Every move, one bar of ``meter`` beats, in every template style and every place of the moves'
    four-beat cycle: ``(K, meter, SAMPLES, 24, 3)`` positions with each beat in its own body frame, and
    the move of each template."""
    from dance_core.synth.dancer import NAMES, Style, render_moves

    grid = style_grid()
    bars = lcm(meter, 4) // meter  # bars start at every beat of the four-beat cycle that a bar line can
    within = np.arange(meter * SAMPLES) / SAMPLES
    out, names = [], []
    for m, move in enumerate(NAMES):
        styles = [s for s in grid if move == "walk" or s["speed"] == grid[0]["speed"]]
        beat = np.tile(np.concatenate([b * meter + within for b in range(bars)]), len(styles))
        per_frame = {k: np.repeat([s[k] for s in styles], bars * len(within)) for k in styles[0]}
        phi = beat - meter * np.floor(beat / meter)
        moves = np.full(len(beat), m)
        motion = render_moves(beat, phi, meter, moves, moves, np.zeros(len(beat)), float(SAMPLES), Style(**per_frame))
        out.append(motion.positions().reshape(-1, meter, SAMPLES, 24, 3))
        names += [move] * len(out[-1])
    return canonicalize(np.concatenate(out), SAMPLES // 2, *SMPL_HIPS).astype(np.float32), tuple(names)


def bar_samples(positions: np.ndarray, fps: float, beats: np.ndarray, meter: int, downbeat: int) -> np.ndarray:
    """The bars of ``meter`` beats from beat ``downbeat`` on, each resampled to ``SAMPLES`` points per beat
    (linear between the beats and between frames) with each beat in its own body frame:
    ``(bars, meter, SAMPLES, J, 3)``; only bars whose closing beat is known and inside the clip."""
    starts = np.arange(downbeat, len(beats) - meter, meter)
    if len(starts) == 0:
        return np.zeros((0, meter, SAMPLES) + positions.shape[1:], np.float32)
    x = starts[:, None] + np.arange(meter * SAMPLES)[None] / SAMPLES
    t = np.interp(x, np.arange(len(beats)), beats) * fps
    lo = np.clip(np.floor(t).astype(np.int64), 0, len(positions) - 1)
    hi = np.minimum(lo + 1, len(positions) - 1)
    w = np.clip(t - lo, 0.0, 1.0)[..., None, None]
    p = (1 - w) * positions[lo] + w * positions[hi]
    p = p.reshape(len(starts), meter, SAMPLES, *positions.shape[1:])
    return canonicalize(p, SAMPLES // 2, *SMPL_HIPS).astype(np.float32)


def bar_distances(bars: np.ndarray, bank: np.ndarray, every: int = SAMPLES) -> np.ndarray:
    """Per bar, the RMS joint distance (m) to the nearest template, or to two templates one after the
    other: a change of move at a sample that is a multiple of ``every`` (a beat, or with kinematic beats
    half a beat), with the half beat before it, where the dancer blends the two moves, not scored:
    ``(bars,)``."""
    n, steps = len(bars), bars.shape[1] * bars.shape[2]
    x = bars.reshape(n, steps, -1)
    tpl = bank.reshape(len(bank), steps, -1)
    d = np.stack([(x[:, i] ** 2).sum(1)[:, None] + (tpl[:, i] ** 2).sum(1)[None] - 2 * x[:, i] @ tpl[:, i].T
                  for i in range(steps)], axis=-1)  # (bars, K, samples): squared distance per sample
    prefix = np.concatenate([np.zeros(d.shape[:2] + (1,), d.dtype), np.cumsum(d, axis=-1)], axis=-1)
    first = prefix.min(axis=1)  # (bars, samples + 1): the best template for the first i samples
    rest = (prefix[..., -1:] - prefix).min(axis=1)  # the best one for the samples from i on
    best = first[:, -1] / steps
    gap = SAMPLES // 2
    for change in range(every, steps + 1, every):  # a change at the bar's end blends in its last half beat
        best = np.minimum(best, (first[:, change - gap] + rest[:, change]) / (steps - gap))
    return np.sqrt(np.maximum(best, 0.0) / bars.shape[3])


def bar_motion(bars: np.ndarray) -> np.ndarray:
    """How much each bar moves: the RMS joint distance (m) of its samples from its mean pose, ``(bars,)``."""
    x = bars.reshape(len(bars), -1, *bars.shape[3:])
    return np.sqrt(((x - x.mean(axis=1, keepdims=True)) ** 2).sum(-1).mean(axis=(1, 2)))


@lru_cache(maxsize=8)
def stillest(meter: int) -> float:
    """How much the stillest template of ``meter`` beats moves (m; a bounce: about 0.023)."""
    return float(bar_motion(templates(meter)[0]).min())


def clip_bars(clip: JointClip, meters: Sequence[int]) -> tuple[np.ndarray, np.ndarray, dict[str, float], str | None]:
    """The distances of a clip's bars under the meter and downbeat that fit best, which of them are held
    still (moving less than half the stillest template: no move, whatever pose they are near), what was
    chosen, and a note when the beats came from the motion."""
    p = check_positions(clip)
    if p.shape[1] != 24:
        raise DataError(f"{WHAT}: {clip.name}: needs the 24 SMPL joints of the synthetic dancer, got {p.shape[1]}")
    note = None
    beats = beats_within(clip.music_beats, clip.duration)
    if len(beats) <= min(meters):
        beats = hip_height_beats(p, clip.fps)
        note = f"{WHAT}: {clip.name}: bars on the dance's own kinematic beats (no music beats)"
    if len(beats) <= min(meters):  # a dance without beats (frozen, say) is scored on a nominal count
        beats = np.arange(0.0, clip.duration, 60.0 / NOMINAL_BPM)
        note = f"{WHAT}: {clip.name}: no music beats and no kinematic beat; bars at a nominal {NOMINAL_BPM:g} bpm"
    best: tuple[float, np.ndarray, np.ndarray, dict[str, float]] | None = None
    for meter in meters:
        bank = templates(meter)[0]
        for downbeat in range(meter):
            bars = bar_samples(p, clip.fps, beats, meter, downbeat)
            if len(bars) == 0:
                continue
            dist = bar_distances(bars, bank, SAMPLES if note is None else SAMPLES // 2)
            if best is None or dist.mean() < best[0]:
                still = bar_motion(bars) < 0.5 * stillest(meter)
                best = (float(dist.mean()), dist, still, {"meter": float(meter), "downbeat": float(downbeat)})
    if best is None:
        raise DataError(f"{WHAT}: {clip.name}: {clip.duration:.2f} s hold no whole bar of {min(meters)} beats")
    return best[1], best[2], best[3], note


class MoveValidity:
    """Share of bars within ``threshold`` m of one of the synthetic dancer's moves, and the mean distance."""

    needs: tuple[str, ...] = ()

    def __init__(self, threshold: float = 0.025, meters: Sequence[int] = (3, 4)):
        self.threshold, self.meters = threshold, tuple(meters)

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """``move_validity`` (share of valid bars, pooled over the set: within ``threshold`` and not held
        still), ``move_distance`` (mean bar distance, m) and ``move_bars``; per clip the same, the still
        bars, and the meter and downbeat chosen."""
        require_clips(generated, 1, WHAT)
        per_clip, notes, pooled = {}, [], []
        for clip in generated:
            try:
                dist, still, chosen, note = clip_bars(clip, self.meters)
            except DataError as exc:
                notes.append(f"{exc}; skipped")
                continue
            if note:
                notes.append(note)
            valid = (dist <= self.threshold) & ~still
            pooled.append((dist, valid))
            per_clip[clip.name] = {"move_validity": float(valid.mean()), "move_distance": float(dist.mean()),
                                   "bars": float(len(dist)), "still_bars": float(still.sum()), **chosen}
        if not pooled:
            raise DataError(f"{WHAT}: no clip could be cut into bars ({'; '.join(notes)})")
        dist, valid = (np.concatenate(x) for x in zip(*pooled, strict=True))
        values = {"move_validity": float(valid.mean()), "move_distance": float(dist.mean()),
                  "move_bars": float(len(dist))}
        return MetricResult(values, per_clip, notes)


def build_move_validity(config: Any, **_: Any) -> MoveValidity:
    """``move-validity``."""
    return MoveValidity(config.threshold, config.meters)
