"""Beat alignment: a dance's own accents moved onto the music's beats by a smooth, bounded time warp.

A generated dance may move like a person and still put its accents anywhere in the beat. The accents
are the body's own (:func:`dance_core.motion.body.body_beats`: pauses of the limbs relative to the
pelvis); each is paired with the nearest beat when it lies within ``reach`` of a beat period of it,
and a monotone time map through those pairs, playing no stretch of the dance more than ``max_rate``
faster or slower, is smoothed and applied (root linear, joint rotations slerped). Nothing is added or
removed: every pose of the dance is played, a little earlier or later. The song's beats are the ones
the composer tracks; the warp needs nothing from the model, so it holds on any song.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import gaussian_filter1d

from dance_core.motion.motion import Motion
from dance_core.motion.rotations import quat_slerp

#: the most a stretch of the dance is sped up or slowed down
MAX_RATE = 1.35
#: an accent is moved to a beat only when it is within this share of a beat period of it
REACH = 0.45
#: the time map is smoothed over this many seconds (a Gaussian's standard deviation)
SMOOTH = 0.04
#: passes of accent finding and warping
PASSES = 3


@dataclass(frozen=True)
class Alignment:
    """What the warp did: accents found and moved, their mean shift (s) and the largest rate used."""

    accents: int
    moved: int
    mean_shift: float
    max_rate: float

    def summary(self) -> dict[str, float]:
        """The figures as a plain dictionary (for a dance's metadata)."""
        return {"accents": self.accents, "moved": self.moved, "mean_shift_s": round(self.mean_shift, 4),
                "max_rate": round(self.max_rate, 3)}


def nearest_beats(accents: np.ndarray, beats: np.ndarray, reach: float = REACH) -> dict[float, float]:
    """Accent-to-beat pairs ``{beat: accent}`` (times in s): each accent's nearest beat when it is within
    ``reach`` of the local beat period, one accent per beat (the nearest)."""
    beats = np.sort(np.asarray(beats, np.float64))
    accents = np.sort(np.asarray(accents, np.float64))
    best: dict[float, float] = {}
    if len(beats) < 2 or not len(accents):
        return best
    period = np.interp(accents, beats[1:], np.diff(beats))
    nearest = np.clip(np.searchsorted(beats, accents), 1, len(beats) - 1)
    left, right = beats[nearest - 1], beats[nearest]
    target = np.where(accents - left <= right - accents, left, right)
    for a, b, ok in zip(accents, target, np.abs(target - accents) <= reach * period, strict=True):
        if ok and (b not in best or abs(a - b) < abs(best[b] - b)):
            best[float(b)] = float(a)
    return best


def anchor_chain(pairs: dict[float, float], duration: float, max_rate: float = MAX_RATE
                 ) -> tuple[np.ndarray, np.ndarray]:
    """``(source, target)`` times (s) of a monotone time map from ``(0, 0)`` to ``(duration, duration)``
    through ``pairs`` (``{target: source}``), taken in order while every piece's rate (source span over
    target span) stays within ``[1 / max_rate, max_rate]``."""
    lo, hi = 1.0 / max_rate, max_rate
    src, dst = [0.0], [0.0]
    for b in sorted(pairs):
        a = pairs[b]
        if 0 < a < duration and dst[-1] < b < duration and a > src[-1] and lo <= (a - src[-1]) / (b - dst[-1]) <= hi:
            src.append(a)
            dst.append(b)
    while len(src) > 1 and not lo <= (duration - src[-1]) / (duration - dst[-1]) <= hi:
        src.pop()
        dst.pop()
    return np.asarray(src + [duration]), np.asarray(dst + [duration])


def sample_frames(motion: Motion, frames: np.ndarray) -> Motion:
    """``motion`` at fractional frame positions ``frames`` (root and joint positions linear, rotations
    slerped), at the same frame rate."""
    frames = np.clip(np.asarray(frames, np.float64), 0, motion.n_frames - 1)
    lo = np.floor(frames).astype(int)
    hi = np.minimum(lo + 1, motion.n_frames - 1)
    w = (frames - lo)[:, None]
    root = (1 - w) * motion.root[lo] + w * motion.root[hi]
    if motion.rotations is None:
        pos = (1 - w[:, None]) * motion.joint_positions[lo] + w[:, None] * motion.joint_positions[hi]
        return replace(motion, root=root, joint_positions=pos, meta=dict(motion.meta))
    rot = quat_slerp(motion.rotations[lo], motion.rotations[hi], w[:, None])
    return replace(motion, root=root, rotations=rot, meta=dict(motion.meta))


def time_map(src: np.ndarray, dst: np.ndarray, n: int, fps: float) -> np.ndarray:
    """The source time (s) of each of ``n`` output frames: the anchors' piecewise-linear map, smoothed
    over ``SMOOTH`` seconds, monotone, from 0 to the last frame's time."""
    t = np.arange(n) / fps
    source = np.interp(t, dst, src)
    if n > 3:
        source = gaussian_filter1d(source, SMOOTH * fps, mode="nearest")
    source[0], source[-1] = 0.0, t[-1]
    return np.maximum.accumulate(np.clip(source, 0.0, t[-1]))


def align_to_beats(motion: Motion, beats: np.ndarray, max_rate: float = MAX_RATE, reach: float = REACH,
                   passes: int = PASSES) -> tuple[Motion, Alignment]:
    """``motion`` time-warped so that its own accents land on ``beats`` (times in s), with what was done;
    the same number of frames. Each pass finds the accents of the dance as warped so far, pairs those on
    beats not yet taken (an accent that lost its beat to a nearer one may find its own once the dance
    has moved), maps them back to the original's time and rebuilds one chain from all pairs, so the
    rate bound holds for the whole map and the original is sampled once. A dance without accents or a
    song without beats comes back unchanged."""
    from dance_core.motion.body import body_beats

    fps, n = motion.fps, motion.n_frames
    duration = (n - 1) / fps
    t = np.arange(n) / fps
    pairs: dict[float, float] = {}
    source, current, found = t, motion, None
    for _ in range(max(1, passes)):
        accents = body_beats(current.positions(), fps, motion.skeleton.names)
        found = len(accents) if found is None else found
        new = {b: float(np.interp(a, t, source)) for b, a in nearest_beats(accents, beats, reach).items()
               if b not in pairs}
        if not new:
            break
        pairs.update(new)
        src, dst = anchor_chain(pairs, duration, max_rate)
        pairs = dict(zip(dst[1:-1].tolist(), src[1:-1].tolist(), strict=True))
        source = time_map(src, dst, n, fps)
        current = sample_frames(motion, source * fps)
    if not pairs:
        return motion, Alignment(found or 0, 0, 0.0, 1.0)
    src, dst = anchor_chain(pairs, duration, max_rate)
    rates = np.diff(src) / np.diff(dst)
    return current, Alignment(found or 0, len(pairs), float(np.mean(np.abs(source - t))),
                              float(max(rates.max(), 1.0 / rates.min())))
