"""Small operations on joint-position clips: resampling, up-axis conversion, guards, speeds."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dance_core.errors import DataError
from dance_core.protocols import JointClip


def resample(positions: np.ndarray, fps_from: float, fps_to: float) -> np.ndarray:
    """Linearly resample ``(T, J, 3)`` positions from one frame rate to another (same duration)."""
    if abs(fps_from - fps_to) < 1e-9:
        return positions
    n = len(positions)
    duration = (n - 1) / fps_from
    m = int(np.floor(duration * fps_to + 1e-6)) + 1
    t = np.arange(m) / fps_to * fps_from
    lo = np.minimum(np.floor(t).astype(np.int64), n - 1)
    hi = np.minimum(lo + 1, n - 1)
    w = (t - lo)[:, None, None]
    return (1 - w) * positions[lo] + w * positions[hi]


def resampled(clip: JointClip, fps: float) -> JointClip:
    """The clip at another frame rate (a copy; beats and names kept)."""
    if abs(clip.fps - fps) < 1e-9:
        return clip
    return JointClip(
        clip.name, resample(clip.positions, clip.fps, fps), fps, clip.joints, clip.music_beats, dict(clip.meta)
    )


def z_up_to_y_up(positions: np.ndarray) -> np.ndarray:
    """Rotate Z-up positions to Y-up (-90 degrees about X): ``(x, y, z) -> (x, z, -y)``."""
    return np.stack([positions[..., 0], positions[..., 2], -positions[..., 1]], axis=-1)


def check_positions(clip: JointClip) -> np.ndarray:
    """The clip's positions as float64 ``(T, J, 3)``; malformed or non-finite input is a DataError."""
    p = np.asarray(clip.positions, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 3:
        raise DataError(f"{clip.name}: joint positions must be (frames, joints, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise DataError(f"{clip.name}: joint positions contain NaN or inf")
    if clip.fps <= 0:
        raise DataError(f"{clip.name}: fps must be positive, got {clip.fps}")
    return p


def require_frames(clip: JointClip, frames: int, what: str) -> np.ndarray:
    """Positions of a clip that has at least ``frames`` frames, else a DataError naming ``what``."""
    p = check_positions(clip)
    if len(p) < frames:
        raise DataError(
            f"{clip.name}: {what} needs at least {frames} frames "
            f"({frames / clip.fps:.2f} s at {clip.fps:g} fps); the clip has {len(p)}"
        )
    return p


def require_clips(clips: Sequence[JointClip] | None, count: int, what: str, role: str = "generated") -> None:
    """A DataError unless the set has at least ``count`` clips."""
    n = 0 if clips is None else len(clips)
    if n < count:
        raise DataError(f"{what} needs at least {count} {role} clip(s); got {n}")


def same_joint_count(generated: Sequence[JointClip], reference: Sequence[JointClip], what: str) -> None:
    """A DataError when the two sets do not share one joint count."""
    counts = {c.positions.shape[1] for c in [*generated, *reference]}
    if len(counts) > 1:
        raise DataError(f"{what}: generated and reference clips have different joint counts {sorted(counts)}")


def joint_speeds(positions: np.ndarray, fps: float) -> np.ndarray:
    """Per-frame joint speeds ``(T, J)`` in units/s (backward differences; frame 0 copies frame 1)."""
    step = np.linalg.norm(np.diff(positions, axis=0), axis=-1) * fps
    return np.concatenate([step[:1], step], axis=0)


def smpl_layout(clip: JointClip, what: str) -> np.ndarray:
    """Positions in SMPL-24 order: 24 joints in body-model order, or named joints that map onto it."""
    p = check_positions(clip)
    if clip.joints is not None and len(clip.joints) == p.shape[1]:
        index = _smpl_index(list(clip.joints))
        if index is not None:
            return p[:, index]
    if p.shape[1] == 24:
        return p
    raise DataError(f"{clip.name}: {what} needs the 24 SMPL joints (AIST++ layout); the clip has {p.shape[1]} joints")


def _smpl_index(names: list[str]) -> list[int] | None:
    from dance_core.motion.skeletons import SMPL_AIST_NAMES, SMPL_NAMES

    for candidates in (SMPL_NAMES, SMPL_AIST_NAMES):
        lowered = [n.lower() for n in names]
        wanted = [c.lower() for c in candidates]
        if all(w in lowered for w in wanted):
            return [lowered.index(w) for w in wanted]
    return None
