"""Realism against real dance: windowed motion statistics, their Fréchet distance, and beat locking
from the body's own movement.

Every function works on joint positions ``(T, J, 3)`` (Y up, the floor at ``y = 0``) with the joints'
names, mapped onto the canonical body by :mod:`dance_core.motion.rig_maps` (any rig a preset knows).
Lengths are divided by the leg length (hip joint to floor at rest, estimated as the median standing
hip height), so dancers of any size and units compare.

**Window statistics** (:func:`window_statistics`): in windows of ``window`` seconds every ``hop``
seconds, what a choreographer looks at, one number each:

- ``knee_bend``, ``elbow_bend``: mean flexion in degrees (0 straight), both sides;
- ``pelvis_bob``: standard deviation of the pelvis height, per leg;
- ``root_travel``: ground-plane path of the hips' midpoint per second, per leg;
- ``turning``: absolute change of the body's heading (the hips' left-right line) per second, radians;
- ``hand_speed``: mean speed of the wrists relative to the pelvis, per leg per second;
- ``foot_speed``: mean horizontal speed of the ankles, per leg per second;
- ``torso_twist``: mean absolute angle between the shoulder line and the hip line, degrees;
- ``arm_raise``: mean angle of the upper arms from hanging straight down, degrees;
- ``weight_changes``: changes of the supporting (lower) foot per second, counted when the other
  foot is clearly lower (by 3 % of the leg) than it had been;
- ``foot_height_range``: the 95th minus the 5th percentile of both ankles' heights, per leg.

**Realism distance** (:func:`realism_distance`): the statistics of both sets standardised with the
reference's mean and standard deviation, then the Fréchet distance between Gaussians fitted to them
(:mod:`dance_core.evaluation.frechet`). Two halves of real dance are the scale it is read against.

**Body beat locking** (:func:`body_locking`): kinematic beats are the local minima of the *body's own*
movement energy, the summed speed of the hands, feet and head relative to the pelvis in the body's
heading frame, so translating or turning a rigid figure moves nothing and gives no beats. Each beat's
phase within its music beat gives ``mean cos(2 pi phase)``: 1 when every accent is on the beat, -1 on
the off-beat, near 0 at random; the wrong-tempo control scores the same beats against a grid 1.13x as
fast (:func:`dance_core.evaluation.quality.wrong_tempo_grid`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dance_core.errors import DataError
from dance_core.evaluation.frechet import frechet_distance
from dance_core.evaluation.quality import beat_phases, wrong_tempo_grid
from dance_core.motion.body import Body, body_beats, hip_heading, leg_length

#: the statistics of :func:`window_statistics`, in column order
STATISTICS = ("knee_bend", "elbow_bend", "pelvis_bob", "root_travel", "turning", "hand_speed", "foot_speed",
              "torso_twist", "arm_raise", "weight_changes", "foot_height_range")
WINDOW, HOP = 4.0, 1.0
#: the other foot must be this much lower (per leg) for the weight to change to it
WEIGHT_MARGIN = 0.03


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = (a * b).sum(-1) / np.maximum(np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1), 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def frame_measures(positions: np.ndarray, fps: float, body: Body, leg: float) -> dict[str, np.ndarray]:
    """Per-frame measures behind the window statistics (see the module's note)."""
    p = np.asarray(positions, np.float64)
    j = body.__getitem__
    knee = np.mean([180 - _angle(p[:, j(f"{s}_Hip")] - p[:, j(f"{s}_Knee")],
                                 p[:, j(f"{s}_Ankle")] - p[:, j(f"{s}_Knee")]) for s in "LR"], axis=0)
    elbow = np.mean([180 - _angle(p[:, j(f"{s}_Shoulder")] - p[:, j(f"{s}_Elbow")],
                                  p[:, j(f"{s}_Wrist")] - p[:, j(f"{s}_Elbow")]) for s in "LR"], axis=0)
    hips = (p[:, j("L_Hip")] + p[:, j("R_Hip")]) / 2
    step = np.linalg.norm(np.diff(hips[:, [0, 2]], axis=0), axis=-1) * fps / leg
    heading = hip_heading(p, body)
    turn = np.abs(np.diff(heading)) * fps
    pelvis = p[:, j("Pelvis")]
    hand = np.mean([np.linalg.norm(np.diff(p[:, j(f"{s}_Wrist")] - pelvis, axis=0), axis=-1) for s in "LR"],
                   axis=0) * fps / leg
    foot = np.mean([np.linalg.norm(np.diff(p[:, j(f"{s}_Ankle"), :][:, [0, 2]], axis=0), axis=-1) for s in "LR"],
                   axis=0) * fps / leg
    shoulders = p[:, j("L_Shoulder")] - p[:, j("R_Shoulder")]
    hipline = p[:, j("L_Hip")] - p[:, j("R_Hip")]
    twist = np.abs(np.degrees(np.angle(np.exp(1j * (np.arctan2(-shoulders[:, 2], shoulders[:, 0])
                                                    - np.arctan2(-hipline[:, 2], hipline[:, 0]))))))
    down = np.array([0.0, -1.0, 0.0])
    raise_ = np.mean([_angle(p[:, j(f"{s}_Elbow")] - p[:, j(f"{s}_Shoulder")], down) for s in "LR"], axis=0)
    pad = lambda x: np.concatenate([x[:1], x])  # noqa: E731 - differences back to one value per frame
    return {"knee_bend": knee, "elbow_bend": elbow, "pelvis_height": pelvis[:, 1] / leg, "root_step": pad(step),
            "turn": pad(turn), "hand_speed": pad(hand), "foot_speed": pad(foot), "torso_twist": twist,
            "arm_raise": raise_, "ankle_heights": p[:, [j("L_Ankle"), j("R_Ankle")], 1] / leg}


def weight_changes(ankle_heights: np.ndarray, margin: float = WEIGHT_MARGIN) -> np.ndarray:
    """``(T,)`` 1 where the supporting foot changes: the other ankle has become lower by ``margin``
    (hysteresis, so a foot sliding level with the other does not flicker)."""
    out = np.zeros(len(ankle_heights))
    support = int(np.argmin(ankle_heights[0]))
    for t in range(1, len(ankle_heights)):
        other = 1 - support
        if ankle_heights[t, other] < ankle_heights[t, support] - margin:
            support = other
            out[t] = 1.0
    return out


def window_statistics(positions: np.ndarray, fps: float, names: Sequence[str], window: float = WINDOW,
                      hop: float = HOP, where: str = "clip") -> np.ndarray:
    """``(W, len(STATISTICS))`` statistics of every ``window``-second window every ``hop`` seconds (none
    when the clip is shorter than one window)."""
    body = Body.of(names, where)
    leg = leg_length(positions, body)
    m = frame_measures(positions, fps, body, leg)
    changes = weight_changes(m["ankle_heights"])
    size, step = int(round(window * fps)), max(1, int(round(hop * fps)))
    rows = []
    for start in range(0, len(positions) - size + 1, step):
        w = slice(start, start + size)
        ankles = m["ankle_heights"][w]
        rows.append([
            m["knee_bend"][w].mean(), m["elbow_bend"][w].mean(), m["pelvis_height"][w].std(),
            m["root_step"][w].mean(), m["turn"][w].mean(), m["hand_speed"][w].mean(), m["foot_speed"][w].mean(),
            m["torso_twist"][w].mean(), m["arm_raise"][w].mean(), changes[w].sum() / window,
            np.percentile(ankles, 95) - np.percentile(ankles, 5),
        ])
    return np.asarray(rows, np.float64).reshape(-1, len(STATISTICS))


def realism_distance(generated: np.ndarray, reference: np.ndarray) -> float:
    """Fréchet distance between the window statistics of ``generated`` and ``reference``, both
    standardised with the reference's mean and standard deviation."""
    if len(generated) < 2 or len(reference) < 2:
        raise DataError(f"realism distance needs at least 2 windows on each side ({len(generated)} and "
                        f"{len(reference)} given)")
    mu, sd = reference.mean(0), reference.std(0)
    sd = np.where(sd > 1e-9, sd, 1.0)
    a, b = (generated - mu) / sd, (reference - mu) / sd
    return frechet_distance(a.mean(0), np.cov(a, rowvar=False), b.mean(0), np.cov(b, rowvar=False))


def on_beat(kinematic_beats: np.ndarray, music_beats: np.ndarray) -> float:
    """``mean cos(2 pi phase)`` of the kinematic beats inside the music's beats: 1 on the beat, -1 on
    the off-beat, ~0 unrelated; NaN with fewer than 4 beats inside."""
    phases = beat_phases(kinematic_beats, music_beats)
    return float(np.cos(2 * np.pi * phases).mean()) if len(phases) >= 4 else float("nan")


def body_locking(positions: np.ndarray, fps: float, names: Sequence[str], music_beats: np.ndarray,
                 where: str = "clip") -> dict[str, float]:
    """On-beat locking of the body's own accents, with the wrong-tempo control and how many beats."""
    beats = body_beats(positions, fps, names, where)
    music = np.asarray(music_beats, np.float64)
    return {"locking": on_beat(beats, music), "control": on_beat(beats, wrong_tempo_grid(music)),
            "accents_per_beat": len(beats) / max(len(music) - 1, 1)}
