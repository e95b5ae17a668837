"""Resampling motion in time: zero-phase low-pass filtering before decimation, slerp in between frames."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation, Slerp

from dance_core.media import frame_count
from dance_core.motion.rotations import unroll_quat

#: low-pass cutoff as a fraction of the target Nyquist frequency
CUTOFF = 0.8


def lowpass(x: np.ndarray, fps: float, target_fps: float) -> np.ndarray:
    """Zero-phase 4th-order Butterworth along axis 0, cut at ``CUTOFF`` of ``target_fps / 2``."""
    if target_fps >= fps or len(x) < 4:
        return np.asarray(x, np.float64)
    sos = butter(4, CUTOFF * target_fps / fps, output="sos")
    return sosfiltfilt(sos, np.asarray(x, np.float64), axis=0, padlen=min(27, len(x) - 1))


def sample_times(n_frames: int, fps: float, target_fps: float) -> np.ndarray:
    """Source frame positions (fractional) of every target frame: frame k is at time k / target_fps."""
    n = frame_count(n_frames / fps, target_fps)
    return np.minimum(np.arange(n) * fps / target_fps, n_frames - 1)


def resample_array(x: np.ndarray, fps: float, target_fps: float) -> np.ndarray:
    """Per-frame values ``(T, ...)`` at another rate: filtered when decimating, linearly interpolated."""
    if abs(fps - target_fps) < 1e-9:
        return np.asarray(x)
    filtered = lowpass(x, fps, target_fps)
    pos = sample_times(len(x), fps, target_fps)
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, len(x) - 1)
    w = (pos - lo).reshape(-1, *([1] * (filtered.ndim - 1)))
    return (1 - w) * filtered[lo] + w * filtered[hi]


def resample_rotations(q: np.ndarray, fps: float, target_fps: float) -> np.ndarray:
    """Quaternions ``(T, J, 4)`` at another rate: hemisphere-aligned, low-pass filtered and
    renormalized when decimating; slerped between the source frames."""
    q = unroll_quat(q)
    if target_fps < fps:
        q = lowpass(q, fps, target_fps)
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
    pos = sample_times(len(q), fps, target_fps)
    if len(q) == 1:
        return np.repeat(q, len(pos), axis=0)
    src = np.arange(len(q))
    out = np.empty((len(pos),) + q.shape[1:])
    for j in range(q.shape[1]):
        out[:, j] = Slerp(src, Rotation.from_quat(q[:, j]))(pos).as_quat()
    return unroll_quat(out)


def resample_motion(motion, fps: float):
    """A :class:`~dance_core.motion.Motion` at ``fps``."""
    if abs(motion.fps - fps) < 1e-9:
        return motion
    root = resample_array(motion.root, motion.fps, fps)
    if motion.rotations is None:
        return replace(motion, fps=fps, root=root,
                       joint_positions=resample_array(motion.joint_positions, motion.fps, fps))
    return replace(motion, fps=fps, root=root, rotations=resample_rotations(motion.rotations, motion.fps, fps))
