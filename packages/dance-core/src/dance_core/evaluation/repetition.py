"""Whether a dance has fallen into a loop: how closely its last stretch repeats a stretch shortly before it.

An autoregressive dancer can settle into a cycle: the same few seconds of dance again and again, to within
centimetres, no longer following the music. Windowed statistics (the realism distance over 4-s windows,
speed, jerk) cannot see it, since every window of a loop is a plausible window of dance. Real dancers
repeat figures, but never to within a few centimetres over tens of seconds: on the seven held-out CMU
takes this distance is 7-23 cm; a looping LSTM dancer scored 0.8-5.5 cm.

:func:`self_repetition`: body poses relative to the pelvis, turned so the hips face one way (a loop that
turns a little on each cycle is still a loop), the last ``window`` seconds compared frame by frame with the
same stretch ``lag`` seconds earlier; the smallest mean joint distance over lags of 0.5-20 s.
:class:`Repetition` is ``dance evaluate``'s metric ``repetition`` over a set of clips.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.evaluation.clips import check_positions, require_clips
from dance_core.protocols import JointClip, MetricResult

#: seconds compared at the end of the dance, and the range of lags searched
WINDOW, MIN_LAG, MAX_LAG = 40.0, 0.5, 20.0
#: metres: a dance whose end repeats itself closer than this has fallen into a loop (held-out real takes:
#: 5.9-17.9 cm on the quality benchmark's songs, 7-23 cm whole)
LOOP_BELOW = 0.05


def facing_poses(positions: np.ndarray, names: Sequence[str] | None = None) -> np.ndarray:
    """``(T, J, 3)`` joints relative to the first joint (the root), turned about the vertical so the hips'
    left-right line lies along +X; relative only, without turning, when the hips cannot be found."""
    p = np.asarray(positions, np.float64)
    rel = p - p[:, :1]
    if names is None:
        return rel
    from dance_core.motion.body import Body, hip_heading

    try:
        body = Body.of(names)
    except DataError:
        return rel
    angle = hip_heading(p, body)
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    out = rel.copy()
    out[..., 0] = c * rel[..., 0] - s * rel[..., 2]
    out[..., 2] = s * rel[..., 0] + c * rel[..., 2]
    return out


def self_repetition(positions: np.ndarray, fps: float, names: Sequence[str] | None = None,
                    window: float = WINDOW, lags: tuple[float, float] = (MIN_LAG, MAX_LAG)) -> float:
    """The smallest mean joint distance (m) between the dance's last ``window`` seconds and the same stretch
    ``lag`` seconds earlier, over ``lags`` (seconds; every frame of lag in between). For shorter dances the
    window shrinks to what the longest lag leaves, and the longest lag to a third of the dance when that
    would leave under 10 s; NaN for a dance under 3 s."""
    poses = facing_poses(positions, names)
    n = len(poses)
    longest = int(round(lags[1] * fps))
    if n - longest < 10 * fps:
        longest = n // 3
    shortest = max(1, int(round(lags[0] * fps)))
    span = min(int(round(window * fps)), n - longest)
    if span < 1 or longest < shortest or n < 3 * fps:
        return float("nan")
    end = poses[n - span:]
    best = np.inf
    for lag in range(shortest, longest + 1):
        earlier = poses[n - span - lag:n - lag]
        best = min(best, float(np.linalg.norm(end - earlier, axis=-1).mean()))
    return best


class Repetition:
    """``repetition``: :func:`self_repetition` of each clip (m), their mean and the smallest; a clip under
    3 s is skipped with a note, one under :data:`LOOP_BELOW` is named as a loop."""

    needs: tuple[str, ...] = ()

    def __call__(self, generated: Sequence[JointClip], reference: Sequence[JointClip] | None = None) -> MetricResult:
        """Score the generated clips (the reference is not used)."""
        require_clips(generated, 1, "repetition")
        per_clip, notes = {}, []
        for clip in generated:
            d = self_repetition(check_positions(clip), clip.fps, list(clip.joints) if clip.joints else None)
            if not np.isfinite(d):
                notes.append(f"repetition: {clip.name}: under 3 s; skipped")
                continue
            per_clip[clip.name] = {"repetition": d}
            if d < LOOP_BELOW:
                notes.append(f"repetition: {clip.name}: its end repeats itself within {100 * d:.1f} cm: a loop "
                             f"(real dance: above {100 * LOOP_BELOW:g} cm)")
        if not per_clip:
            raise DataError("repetition: every clip is under 3 s")
        values = [v["repetition"] for v in per_clip.values()]
        return MetricResult({"repetition": float(np.mean(values)), "repetition_min": float(np.min(values))},
                            per_clip, notes)


def build_repetition(config: Any, **_: Any) -> Repetition:
    """``repetition``."""
    return Repetition()
