"""AIST++ kinetic motion features: per joint, mean horizontal and vertical kinetic energy and mean
energy expenditure (3 values per joint, 72 for SMPL's 24 joints).

Definitions (after the AIST++ API's ``extract_kinetic_features``, which FACT and Bailando use):
for every frame ``i`` in ``1..T-1`` the velocity is the mean of the frame displacements
``p[k] - p[k-1]`` over ``k`` in ``[i-w, i+w]`` (clipped to the clip) divided by the frame time;
the kinetic energies are the means over frames of ``|v_horizontal|^2`` and ``v_up^2`` (no 1/2 m);
the energy expenditure is the mean over frames of the norm of the windowed mean acceleration.

``compat=False`` (the default) uses the corrected definitions at the clip's own frame rate:
acceleration ``(p[k+1] - 2 p[k] + p[k-1]) / dt^2``, ``dt = 1/fps``, and a window of
``w = max(1, round(2 * fps / 60))`` frames (two frames at 60 fps, the same span in seconds at
other rates). ``compat=True`` reproduces the reference code exactly: the clip is resampled to
60 fps, ``dt = 1/60``, ``w = 2``, and the acceleration keeps its operator-precedence bug,
``v1 = p[k] - p[k-1] / dt``, which makes the energy expenditure depend on absolute position.
The two modes differ only in the energy-expenditure values at 60 fps.
"""

from __future__ import annotations

import numpy as np

from dance_core.evaluation.clips import require_frames, resample
from dance_core.protocols import JointClip

REFERENCE_FPS = 60.0
MIN_FRAMES = 3


def _window_sums(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Sums of ``x[lo..hi]`` (inclusive, per row of ``lo``/``hi``) along axis 0 via a cumulative sum."""
    c = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)], axis=0)
    return c[hi + 1] - c[lo]


def kinetic_features_array(positions: np.ndarray, fps: float, compat: bool = False) -> np.ndarray:
    """Kinetic features ``(3 J,)`` of Y-up positions ``(T, J, 3)``: per joint [KE_h, KE_v, EE]."""
    p = np.asarray(positions, dtype=np.float64)
    if compat:
        p = resample(p, fps, REFERENCE_FPS)
        fps, w = REFERENCE_FPS, 2
    else:
        w = max(1, int(round(2 * fps / REFERENCE_FPS)))
    dt = 1.0 / fps
    t = len(p)
    frames = np.arange(1, t)  # frames 1..T-1
    disp = np.diff(p, axis=0)  # disp[k-1] = p[k] - p[k-1], k = 1..T-1
    lo = np.maximum(frames - w, 1)
    hi = np.minimum(frames + w, t - 1)
    count = (hi - lo + 1)[:, None, None]
    vel = _window_sums(disp, lo - 1, hi - 1) / (count * dt)  # (T-1, J, 3)
    ke_h = (vel[..., 0] ** 2 + vel[..., 2] ** 2).mean(axis=0)
    ke_v = (vel[..., 1] ** 2).mean(axis=0)
    ks = np.arange(1, t - 1)  # accelerations exist for k = 1..T-2
    if compat:
        v2 = (p[ks + 1] - p[ks]) / dt
        v1 = p[ks] - p[ks - 1] / dt  # the reference's precedence bug, kept on purpose
        acc = (v2 - v1) / dt
    else:
        acc = (p[ks + 1] - 2 * p[ks] + p[ks - 1]) / dt**2
    a_lo = np.maximum(frames - w, 1)
    a_hi = np.minimum(frames + w, t - 2)
    a_count = (a_hi - a_lo + 1)[:, None, None]
    mean_acc = _window_sums(acc, a_lo - 1, a_hi - 1) / a_count
    ee = np.linalg.norm(mean_acc, axis=-1).mean(axis=0)
    return np.stack([ke_h, ke_v, ee], axis=1).reshape(-1)


def kinetic_features(clip: JointClip, compat: bool = False) -> np.ndarray:
    """Kinetic features of a clip, with the first frame's root moved to the origin (zero start)."""
    p = require_frames(clip, MIN_FRAMES, "kinetic features")
    p = p - p[:1, :1]
    return kinetic_features_array(p, clip.fps, compat)
