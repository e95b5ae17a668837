"""A dancer's body read from its joint positions: its canonical joints (any rig a preset of
:mod:`dance_core.motion.rig_maps` knows), its leg length, its heading, and the accents of its own
movement (pauses of the limbs relative to the body), which the realism measures
(:mod:`dance_core.evaluation.realism`) score and the motion graph (:mod:`dance_core.synth.motion_graph`)
cuts real takes at.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from dance_core.errors import DataError

_NEEDED = ("Pelvis", "L_Hip", "R_Hip", "L_Knee", "R_Knee", "L_Ankle", "R_Ankle", "L_Shoulder", "R_Shoulder",
           "L_Elbow", "R_Elbow", "L_Wrist", "R_Wrist", "Head")


@dataclass(frozen=True)
class Body:
    """Canonical joint indices of a clip's joints (see :mod:`dance_core.motion.rig_maps`)."""

    joints: dict[str, int]

    @classmethod
    def of(cls, names: Sequence[str], where: str = "clip") -> Body:
        """The canonical joints among ``names``; a one-line error naming what is missing."""
        from dance_core.motion.rig_maps import detect_map

        found = detect_map(list(names), where).joints
        missing = [n for n in _NEEDED if n not in found]
        if missing:
            raise DataError(f"{where}: realism statistics need the joints {', '.join(missing)}")
        return cls(found)

    def __getitem__(self, name: str) -> int:
        return self.joints[name]


def leg_length(positions: np.ndarray, body: Body) -> float:
    """The leg length of a dancer: the median height of its hips' midpoint over the frames when it stands
    tallest (the 90th percentile), measured from its lowest ankle less the ankle's share (6 %)."""
    hips = (positions[:, body["L_Hip"], 1] + positions[:, body["R_Hip"], 1]) / 2
    ankles = np.minimum(positions[:, body["L_Ankle"], 1], positions[:, body["R_Ankle"], 1])
    standing = np.percentile(hips - ankles, 90)
    return float(max(standing * 1.06, 1e-6))


def hip_heading(positions: np.ndarray, body: Body) -> np.ndarray:
    """Per-frame heading angle (radians) of the hips' left-right line on the floor."""
    left = positions[:, body["L_Hip"]] - positions[:, body["R_Hip"]]
    return np.unwrap(np.arctan2(-left[:, 2], left[:, 0]))


def body_energy(positions: np.ndarray, fps: float, body: Body, leg: float, smooth: float = 0.05) -> np.ndarray:
    """``(T,)`` the summed speed (per leg) of the wrists, ankles and head relative to the pelvis, in the
    body's heading frame: what the body itself moves, not where the whole figure goes or faces."""
    p = np.asarray(positions, np.float64)
    rel = p[:, [body[n] for n in ("L_Wrist", "R_Wrist", "L_Ankle", "R_Ankle", "Head")]] - p[:, None, body["Pelvis"]]
    heading = hip_heading(p, body)
    c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
    local = np.stack([c * rel[..., 0] - s * rel[..., 2], rel[..., 1], s * rel[..., 0] + c * rel[..., 2]], axis=-1)
    speed = np.linalg.norm(np.gradient(local, axis=0), axis=-1).sum(1) * fps / leg
    return gaussian_filter1d(speed, smooth * fps) if smooth > 0 else speed


def body_beats(positions: np.ndarray, fps: float, names: Sequence[str], where: str = "clip",
               min_gap: float = 0.2) -> np.ndarray:
    """Times (s) of the body's accents: local minima of :func:`body_energy` at least ``min_gap``
    seconds apart and below the clip's median energy (a pause between movements, not noise on a
    still body)."""
    body = Body.of(names, where)
    energy = body_energy(positions, fps, body, leg_length(positions, body))
    return energy_minima(energy, fps, min_gap) / fps


def energy_minima(energy: np.ndarray, fps: float, min_gap: float = 0.2) -> np.ndarray:
    """Frame indices (float) of the accents in a body's energy (:func:`body_beats`' rule): each the lowest
    within ``min_gap`` / 2 either side, below the median energy, and at least 5 % of the median under the
    highest there. Empty for fewer than 3 frames or a still body."""
    energy = np.asarray(energy, np.float64)
    order = max(1, int(round(min_gap * fps / 2)))
    if len(energy) < max(3, 2 * order + 1) or energy.max() < 1e-6:
        return np.zeros(0)
    windows = np.lib.stride_tricks.sliding_window_view(energy, 2 * order + 1)
    middle, median = energy[order : len(energy) - order], np.median(energy)
    keep = (middle == windows.min(1)) & (middle < median) & (windows.max(1) - middle > 0.05 * median)
    return np.flatnonzero(keep).astype(np.float64) + order
