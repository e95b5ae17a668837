"""EDGE's Physical Foot Contact score (PFC): feet that slide while the body accelerates.

Per frame: the root's acceleration (second difference of joint 0) with its downward component
removed (upward acceleration counts, falling freely does not), as a norm divided by its maximum
over the clip, times ``min(left ankle, left toe) * min(right ankle, right toe)`` horizontal foot
speeds. The clip's score is the mean over frames and the set's the mean over clips, times 10,000.
A foot on the ground cannot slide unless the other one carries the body, so a low score is good.

EDGE works at 30 fps with per-frame foot displacements; to make the score independent of the
frame rate, foot speeds are expressed as displacement per 1/30 s (``speed / 30``), which is
EDGE's value exactly at 30 fps.
"""

from __future__ import annotations

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.skeletons import FEET_BY_NAME, SMPL_FEET
from dance_core.protocols import JointClip

EDGE_FPS = 30.0
SCALE = 10_000.0


def foot_indices(clip: JointClip, feet: list[str] | None = None) -> tuple[int, int, int, int]:
    """Indices of the left ankle, left toe, right ankle and right toe joints of a clip."""
    names = list(clip.joints) if clip.joints is not None else None
    if feet is not None:
        if names is None:
            raise DataError(f"{clip.name}: PFC feet are given by name but the clip has no joint names")
        missing = [f for f in feet if f not in names]
        if missing:
            raise DataError(f"{clip.name}: PFC: no joint named {', '.join(missing)}")
        return tuple(names.index(f) for f in feet)  # type: ignore[return-value]
    if names is not None:
        for candidate in FEET_BY_NAME:
            if all(c in names for c in candidate):
                return tuple(names.index(c) for c in candidate)  # type: ignore[return-value]
    if clip.positions.shape[1] == 24:
        return SMPL_FEET
    raise DataError(
        f"{clip.name}: PFC needs ankle and toe joints (SMPL-24 or named feet); "
        f"the clip has {clip.positions.shape[1]} unnamed joints"
    )


def pfc_clip(positions: np.ndarray, fps: float, feet: tuple[int, int, int, int]) -> float | None:
    """The clip's mean foot-contact violation (not yet scaled); None when the root never accelerates."""
    root = positions[:, 0]
    acc = (root[2:] - 2 * root[1:-1] + root[:-2]) * fps**2
    acc[:, 1] = np.maximum(acc[:, 1], 0.0)
    acc = np.linalg.norm(acc, axis=-1)
    peak = acc.max()
    if peak <= 0:
        return None
    acc = acc / peak
    f = positions[:, list(feet)]
    horizontal = f[2:, :, [0, 2]] - f[1:-1, :, [0, 2]]
    speed = np.linalg.norm(horizontal, axis=-1) * fps / EDGE_FPS  # per 1/30 s
    left = np.minimum(speed[:, 0], speed[:, 1])
    right = np.minimum(speed[:, 2], speed[:, 3])
    return float((left * right * acc).mean())
