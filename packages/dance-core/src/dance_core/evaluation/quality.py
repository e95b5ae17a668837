"""Dance-quality measures for long generated dances: beat locking, floor contact, smoothness, drift.

Every function works on joint positions ``(T, J, 3)`` in metres, Y up, the floor at ``y = 0``, at
a frame rate ``fps``; beat times are in seconds. ``benchmarks/dance_quality.py`` prints them for a
model against reference dances; :func:`quality_scores` collects the per-dance values.

- **Phase locking** (:func:`phase_locking`): each kinematic beat inside a music beat interval
  ``[b_i, b_{i+1})`` gets the phase ``(t - b_i) / (b_{i+1} - b_i)``; the score is the length of the
  circular mean of ``exp(2 pi i phase)``: 1 when every kinematic beat falls at the same phase of
  the beat (not necessarily on it), about ``1 / sqrt(n)`` for ``n`` beats at random phases.
  Kinematic beats come from two detectors: minima of the summed joint speed (FACT's,
  :func:`dance_core.evaluation.beats.fact_motion_beats`) and minima of the pelvis height
  (:func:`hip_height_beats`). The **wrong-tempo control** scores the same beats against a grid of
  tempo x1.13 over the same span (:func:`wrong_tempo_grid`): a dance locked to the music keeps a
  high score against the right grid and a low one against this grid; a motion with one dominant
  period of its own can score high against any grid whose period divides it, which the control
  exposes. The detectors see different things: a plain bounce has speed minima at its top *and*
  its bottom, half a beat apart, whose phases cancel (speed locking ~0), while its pelvis-height
  minima come once per beat (hips locking ~1); hence both are reported and the better one counts.
- **Floor contact**: per foot the lowest of ankle and toe (:func:`foot_heights`), or its sole where the
  skeleton says where the sole is (``soles``, from grounding: a dancer on the balls of her feet has her
  toe joint a few cm up while her sole is on the floor); *floating* =
  both feet more than 5 cm above the floor; *below floor* = the lowest foot more than 5 cm under
  it; the median lowest-foot height per 10-s stretch (:func:`stretch_medians`).
- **Foot skating** (:func:`foot_skating`): horizontal speed of the lowest foot while it touches
  the floor (below 5 cm).
- **Smoothness** (:func:`derivative_norm`): mean norm of the k-th finite difference times
  ``fps^k`` (speed m/s, acceleration m/s^2, jerk m/s^3); compare models with references at the
  same frame rate, since finite differences of noise grow with it.
- **Drift** (:func:`speed_drift`, :func:`foot_height_trend`): the last stretch's mean speed over
  the first's, and the slope of the lowest-foot height.
- **Bone-length constancy** (:func:`bone_length_constancy`): std / mean of every parent-child
  distance over time, the worst bone; 0 for forward kinematics of a rigid skeleton.
- **Diversity** (:func:`diversity`): mean pairwise distance between several dances of one song.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dance_core.evaluation.beats import fact_motion_beats, local_minima, mean_joint_speed
from dance_core.evaluation.contact import foot_indices
from dance_core.evaluation.kinetic import kinetic_features_array
from dance_core.evaluation.repetition import self_repetition
from dance_core.protocols import JointClip

#: a foot higher than this (m) is off the floor; lower, it may be touching it
FLOAT_HEIGHT = 0.05
#: the lowest foot under this height (m) is in the floor
BELOW_FLOOR = -0.05
#: tempo factor of the wrong-tempo control grid
CONTROL_TEMPO = 1.13
#: length (s) of the stretches whose median lowest-foot height is reported
STRETCH_SECONDS = 10.0
#: length (s) of the first and last stretches compared by the drift ratio
DRIFT_SECONDS = 30.0
#: minima of the pelvis height count within +- this many seconds (FACT's 10 frames at 60 fps)
HIP_ORDER_SECONDS = 10 / 60


# --- beat locking -------------------------------------------------------------------------------


def beat_phases(events: np.ndarray, music_beats: np.ndarray) -> np.ndarray:
    """Phase in ``[0, 1)`` of every event inside a beat interval ``[b_i, b_{i+1})``; others are dropped."""
    beats = np.sort(np.asarray(music_beats, dtype=np.float64))
    t = np.asarray(events, dtype=np.float64)
    if len(beats) < 2 or len(t) == 0:
        return np.zeros(0)
    t = t[(t >= beats[0]) & (t < beats[-1])]
    i = np.clip(np.searchsorted(beats, t, side="right") - 1, 0, len(beats) - 2)
    width = beats[i + 1] - beats[i]
    keep = width > 0
    return ((t[keep] - beats[i][keep]) / width[keep]) % 1.0


def phase_locking(kinematic_beats: np.ndarray, music_beats: np.ndarray) -> float:
    """Length of the circular mean of ``exp(2 pi i phase)`` over the kinematic beats' beat phases.

    1: every kinematic beat at the same phase of its music beat interval; ~0: random phases.
    NaN when no kinematic beat falls between the first and the last music beat.
    """
    phases = beat_phases(kinematic_beats, music_beats)
    if len(phases) == 0:
        return float("nan")
    return float(np.abs(np.exp(2j * np.pi * phases).mean()))


def wrong_tempo_grid(music_beats: np.ndarray, factor: float = CONTROL_TEMPO) -> np.ndarray:
    """A regular grid at ``factor`` times the beats' tempo from the first beat over the same span.

    Its period is the median beat interval divided by ``factor``.
    """
    beats = np.sort(np.asarray(music_beats, dtype=np.float64))
    if len(beats) < 2:
        return beats.copy()
    period = float(np.median(np.diff(beats))) / factor
    n = int(np.floor((beats[-1] - beats[0]) / period + 1e-9)) + 1
    return beats[0] + period * np.arange(n)


def hip_height_beats(
    positions: np.ndarray, fps: float, hips: int = 0, order_seconds: float = HIP_ORDER_SECONDS
) -> np.ndarray:
    """Times of the local minima (over +-``order_seconds``) of the pelvis (joint ``hips``) height."""
    return local_minima(positions[:, hips, 1], int(round(order_seconds * fps))) / fps


def kinematic_beats(positions: np.ndarray, fps: float, hips: int = 0) -> dict[str, np.ndarray]:
    """Kinematic beat times by detector: ``speed`` (FACT's summed joint speed minima), ``hips`` (pelvis height)."""
    return {"speed": fact_motion_beats(positions, fps), "hips": hip_height_beats(positions, fps, hips)}


def beat_locking(
    positions: np.ndarray, fps: float, music_beats: np.ndarray, hips: int = 0, factor: float = CONTROL_TEMPO
) -> dict[str, float]:
    """Phase locking of both detectors against the music beats and against the wrong-tempo grid.

    Keys ``locking_<detector>`` and ``control_<detector>`` per detector; ``locking`` and ``control``
    are the better (higher) of the detectors, chosen for each separately so the control gets the
    same benefit of the choice; ``locking_ratio`` = locking / control.
    """
    grid = wrong_tempo_grid(music_beats, factor)
    out: dict[str, float] = {}
    for name, events in kinematic_beats(positions, fps, hips).items():
        out[f"locking_{name}"] = phase_locking(events, music_beats)
        out[f"control_{name}"] = phase_locking(events, grid)
    names = ("speed", "hips")
    out["locking"] = _nanmax([out[f"locking_{n}"] for n in names])
    out["control"] = _nanmax([out[f"control_{n}"] for n in names])
    out["locking_ratio"] = _ratio(out["locking"], out["control"])
    return out


# --- feet and floor -----------------------------------------------------------------------------


def feet_of(positions: np.ndarray, names: Sequence[str] | None = None) -> tuple[int, int, int, int]:
    """Indices of (left ankle, left toe, right ankle, right toe): by joint name, else SMPL-24's order."""
    return foot_indices(JointClip("motion", positions, 1.0, list(names) if names is not None else None))


def foot_heights(positions: np.ndarray, feet: tuple[int, int, int, int]) -> np.ndarray:
    """``(T, 2)`` height of the left and right foot: the lower of its ankle and toe joints."""
    y = positions[:, list(feet), 1]
    return np.stack([np.minimum(y[:, 0], y[:, 1]), np.minimum(y[:, 2], y[:, 3])], axis=1)


def lowest_foot(positions: np.ndarray, feet: tuple[int, int, int, int], heights: np.ndarray | None = None
                ) -> np.ndarray:
    """``(T,)`` height of the lower foot per frame (of ``heights``, the feet's ``(T, 2)`` sole heights,
    when given: :func:`dance_core.motion.grounding.soles` knows the soles below the joints)."""
    return (foot_heights(positions, feet) if heights is None else np.asarray(heights)).min(axis=1)


def floating_fraction(positions: np.ndarray, feet: tuple[int, int, int, int], height: float = FLOAT_HEIGHT,
                      heights: np.ndarray | None = None) -> float:
    """Fraction of frames with both feet more than ``height`` above the floor."""
    return float((lowest_foot(positions, feet, heights) > height).mean())


def below_floor_fraction(positions: np.ndarray, feet: tuple[int, int, int, int], depth: float = BELOW_FLOOR,
                         heights: np.ndarray | None = None) -> float:
    """Fraction of frames whose lowest foot is under ``depth`` (default 5 cm below the floor)."""
    return float((lowest_foot(positions, feet, heights) < depth).mean())


def stretches(n_frames: int, fps: float, seconds: float = STRETCH_SECONDS) -> list[slice]:
    """Consecutive ``seconds``-long frame ranges; a remainder shorter than half a stretch joins the last."""
    size = max(1, int(round(seconds * fps)))
    starts = list(range(0, n_frames, size))
    if len(starts) > 1 and n_frames - starts[-1] < size / 2:
        starts.pop()
    ends = starts[1:] + [n_frames]
    return [slice(a, b) for a, b in zip(starts, ends, strict=True)]


def stretch_medians(
    positions: np.ndarray, fps: float, feet: tuple[int, int, int, int], seconds: float = STRETCH_SECONDS,
    heights: np.ndarray | None = None,
) -> np.ndarray:
    """Median lowest-foot height of every ``seconds``-long stretch (see :func:`stretches`)."""
    low = lowest_foot(positions, feet, heights)
    return np.array([np.median(low[s]) for s in stretches(len(low), fps, seconds)])


def foot_skating(
    positions: np.ndarray, fps: float, feet: tuple[int, int, int, int], height: float = FLOAT_HEIGHT
) -> float:
    """Mean horizontal speed (m/s) of a foot while it is in contact: the lower foot, under ``height``.

    A foot's point is its lower joint (ankle or toe) in that frame; speeds are central differences.
    NaN when no frame has a foot in contact.
    """
    p = positions[:, list(feet)]  # (T, 4, 3)
    speed = np.linalg.norm(np.gradient(p[..., [0, 2]], axis=0), axis=-1) * fps  # (T, 4)
    heights = foot_heights(positions, feet)
    side = np.argmin(heights, axis=1)  # 0 left, 1 right
    rows = np.arange(len(p))
    ankle, toe = 2 * side, 2 * side + 1
    joint = np.where(p[rows, ankle, 1] <= p[rows, toe, 1], ankle, toe)
    contact = heights[rows, side] < height
    if not contact.any():
        return float("nan")
    return float(speed[rows, joint][contact].mean())


# --- smoothness, drift, rigidity, diversity -----------------------------------------------------


def derivative_norm(positions: np.ndarray, fps: float, order: int) -> float:
    """Mean over joints and frames of the norm of the ``order``-th finite difference times ``fps^order``."""
    if len(positions) <= order:
        return float("nan")
    d = np.diff(np.asarray(positions, dtype=np.float64), n=order, axis=0)
    return float(np.linalg.norm(d, axis=-1).mean() * fps**order)


def smoothness(positions: np.ndarray, fps: float) -> dict[str, float]:
    """Mean ``speed`` (m/s), ``acceleration`` (m/s^2) and ``jerk`` (m/s^3) over joints and frames."""
    return {k: derivative_norm(positions, fps, n) for n, k in enumerate(("speed", "acceleration", "jerk"), 1)}


def speed_drift(positions: np.ndarray, fps: float, seconds: float = DRIFT_SECONDS) -> float:
    """Mean joint speed of the last ``seconds`` over that of the first ``seconds``.

    For dances shorter than two stretches the stretches are the first and last halves instead
    (never overlapping). NaN when the first stretch does not move.
    """
    speed = mean_joint_speed(np.asarray(positions, dtype=np.float64)) * fps
    n = min(int(round(seconds * fps)), len(speed) // 2)
    if n < 1:
        return float("nan")
    return _ratio(float(speed[-n:].mean()), float(speed[:n].mean()))


def foot_height_trend(positions: np.ndarray, fps: float, feet: tuple[int, int, int, int],
                      heights: np.ndarray | None = None) -> float:
    """Least-squares slope of the lowest-foot height over time, in metres per minute."""
    low = lowest_foot(positions, feet, heights)
    if len(low) < 2:
        return float("nan")
    t = np.arange(len(low)) / fps / 60.0
    return float(np.polyfit(t, low, 1)[0])


def bone_lengths(positions: np.ndarray, parents: Sequence[int]) -> np.ndarray:
    """``(T, B)`` distance of every joint with a parent to its parent, in joint order."""
    child = np.array([j for j, p in enumerate(parents) if p >= 0], dtype=np.int64)
    parent = np.array([parents[j] for j in child], dtype=np.int64)
    return np.linalg.norm(positions[:, child] - positions[:, parent], axis=-1)


def bone_length_constancy(positions: np.ndarray, parents: Sequence[int], min_length: float = 1e-3) -> float:
    """Largest std / mean over time of a parent-child distance (bones shorter than ``min_length`` m skipped)."""
    lengths = bone_lengths(np.asarray(positions, dtype=np.float64), parents)
    mean = lengths.mean(axis=0)
    keep = mean > min_length
    if not keep.any():
        return float("nan")
    return float((lengths[:, keep].std(axis=0) / mean[keep]).max())


def pose_features(positions: np.ndarray) -> np.ndarray:
    """``(T, 3 J)`` root-relative joint positions per frame (the pose without where the dancer stands)."""
    p = np.asarray(positions, dtype=np.float64)
    return (p - p[:, :1]).reshape(len(p), -1)


def diversity(samples: Sequence[np.ndarray], fps: float | None = None, features: str = "pose") -> float:
    """Mean pairwise distance between dances of one song; NaN for fewer than two.

    ``features="pose"``: the mean over frames (cropped to the shortest dance) of the Euclidean
    distance between root-relative poses, in metres. ``"kinetic"``: the distance between the dances'
    AIST++ kinetic feature vectors (:mod:`dance_core.evaluation.kinetic`; needs ``fps``).
    """
    if len(samples) < 2:
        return float("nan")
    if features == "pose":
        n = min(len(s) for s in samples)
        vectors = [pose_features(s[:n]) for s in samples]
        dist = lambda a, b: float(np.linalg.norm(a - b, axis=-1).mean())  # noqa: E731
    elif features == "kinetic":
        if fps is None:
            raise ValueError("kinetic diversity needs fps")
        vectors = [kinetic_features_array(np.asarray(s) - np.asarray(s)[:1, :1], fps) for s in samples]
        dist = lambda a, b: float(np.linalg.norm(a - b))  # noqa: E731
    else:
        raise ValueError(f"unknown diversity features {features!r} (pose or kinetic)")
    pairs = [dist(vectors[i], vectors[j]) for i in range(len(vectors)) for j in range(i + 1, len(vectors))]
    return float(np.mean(pairs))


# --- everything for one dance -------------------------------------------------------------------


def quality_scores(
    positions: np.ndarray,
    fps: float,
    music_beats: np.ndarray,
    names: Sequence[str] | None = None,
    parents: Sequence[int] | None = None,
    soles: np.ndarray | None = None,
) -> dict[str, float]:
    """Every per-dance measure of this module as one flat dict (see the module docstring); the floor
    measures on ``soles`` ``(T, 2)`` when given (:func:`dance_core.motion.grounding.soles`), else on
    the lower of each foot's ankle and toe joints.

    Keys: the :func:`beat_locking` keys; ``float`` and ``below_floor`` (fractions), ``worst_stretch``
    (highest 10-s median lowest-foot height, m), ``skating`` (m/s), ``speed``, ``acceleration``,
    ``jerk``, ``drift`` (last/first 30 s speed), ``drift_60`` (last/first minute, NaN under 2
    minutes), ``repeat`` (m: how closely the end repeats itself, :func:`~dance_core.evaluation.repetition.
    self_repetition`; a loop scores near 0), ``foot_trend`` (m/min), ``bone`` (NaN without ``parents``),
    ``seconds``.
    """
    p = np.asarray(positions, dtype=np.float64)
    feet = feet_of(p, names)
    out = beat_locking(p, fps, music_beats)
    medians = stretch_medians(p, fps, feet, heights=soles)
    out.update(
        float=floating_fraction(p, feet, heights=soles),
        below_floor=below_floor_fraction(p, feet, heights=soles),
        worst_stretch=float(medians.max()) if len(medians) else float("nan"),
        skating=foot_skating(p, fps, feet),
    )
    out.update(smoothness(p, fps))
    out["drift"] = speed_drift(p, fps, DRIFT_SECONDS)
    out["drift_60"] = speed_drift(p, fps, 60.0) if len(p) >= 120 * fps else float("nan")
    out["repeat"] = self_repetition(p, fps, names)
    out["foot_trend"] = foot_height_trend(p, fps, feet, soles)
    out["bone"] = bone_length_constancy(p, parents) if parents is not None else float("nan")
    out["seconds"] = len(p) / fps
    return out


def _nanmax(values: Sequence[float]) -> float:
    finite = [v for v in values if np.isfinite(v)]
    return float(max(finite)) if finite else float("nan")


def _ratio(a: float, b: float) -> float:
    return float(a / b) if np.isfinite(a) and np.isfinite(b) and b > 0 else float("nan")
