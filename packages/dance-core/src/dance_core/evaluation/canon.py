"""A canonical body frame for windows of joint positions: root at the origin, hips facing +Z.

Motion matching, motion prediction and the heading-free pose metrics (FPD, FMD, sample diversity)
compare motions wherever and whichever way they happen on the floor. :func:`canonicalize` moves a
window so that at one *anchor* frame the root's horizontal position is the origin and the body
faces +Z (the left hip on +X), by a translation in the floor plane and a rotation about the
vertical (Y) axis; heights are left as they are. :func:`canonical_windows` does so for every
window of a few consecutive frames.
"""

from __future__ import annotations

import numpy as np

from dance_core.errors import DataError
from dance_core.protocols import JointClip

#: SMPL-24 indices of the left and right hips
SMPL_HIPS = (1, 2)
#: left and right hip joint names in the skeletons we know (SMPL, AIST++ features, Mixamo, common BVH)
HIPS_BY_NAME = (
    ("L_Hip", "R_Hip"),
    ("lhip", "rhip"),
    ("LeftUpLeg", "RightUpLeg"),
    ("LeftHip", "RightHip"),
)


def hip_indices(clip: JointClip, hips: list[str] | tuple[str, str] | None = None) -> tuple[int, int]:
    """Indices of a clip's left and right hip joints: named ones, known names, or SMPL-24 order."""
    names = list(clip.joints) if clip.joints is not None else None
    if hips is not None:
        missing = [h for h in hips if names is None or h not in names]
        if missing:
            raise DataError(f"{clip.name}: no joint named {', '.join(missing)} (the hips option)")
        return names.index(hips[0]), names.index(hips[1])  # type: ignore[union-attr]
    if names is not None:
        for left, right in HIPS_BY_NAME:
            if left in names and right in names:
                return names.index(left), names.index(right)
    if np.shape(clip.positions)[1] == 24:
        return SMPL_HIPS
    raise DataError(
        f"{clip.name}: needs the left and right hip joints to find the body's heading (SMPL-24, known "
        f"joint names, or the hips option); the clip has {np.shape(clip.positions)[1]} joints"
    )


def heading(pose: np.ndarray, left: int, right: int) -> np.ndarray:
    """Unit horizontal facing direction ``(..., 2)`` as (x, z) of poses ``(..., J, 3)``.

    The facing is perpendicular to the right-to-left hip vector in the floor plane (left hip on +X
    means facing +Z); hips at the same horizontal spot give +Z.
    """
    across = pose[..., left, :] - pose[..., right, :]
    facing = np.stack([-across[..., 2], across[..., 0]], axis=-1)
    norm = np.linalg.norm(facing, axis=-1, keepdims=True)
    flat = norm[..., 0] < 1e-9
    facing = np.where(flat[..., None], np.array([0.0, 1.0]), facing / np.where(flat, 1.0, norm[..., 0])[..., None])
    return facing


def canonicalize(positions: np.ndarray, anchor: int, left: int, right: int, root: int = 0) -> np.ndarray:
    """Windows ``(..., F, J, 3)`` in their anchor frame's body frame.

    Each window is translated so that the root's horizontal position at frame ``anchor`` is the
    origin, and rotated about Y so that the body faces +Z at that frame (see :func:`heading`).
    The result does not depend on where the window happened on the floor or which way it faced.
    """
    p = np.asarray(positions, dtype=np.float64)
    at = p[..., anchor, :, :]
    sin_cos = heading(at, left, right)  # facing = (sin a, cos a) for the yaw a
    s, c = sin_cos[..., 0][..., None, None], sin_cos[..., 1][..., None, None]
    dx = p[..., 0] - at[..., root, 0][..., None, None]
    dz = p[..., 2] - at[..., root, 2][..., None, None]
    return np.stack([c * dx - s * dz, p[..., 1], s * dx + c * dz], axis=-1)


def canonical_windows(positions: np.ndarray, span: int, left: int, right: int, anchor: int | None = None) -> np.ndarray:
    """Every window of ``span`` consecutive frames of ``(T, J, 3)`` positions, each in its own body frame.

    Returns ``(T - span + 1, span, J, 3)``: window ``i`` holds frames ``i .. i + span - 1``
    canonicalized at its frame ``anchor`` (default the middle one, ``span // 2``; see
    :func:`canonicalize`), so where and which way the dancer faced does not matter while the
    window's own turning and travelling stay in.
    """
    return canonicalize(sliding_windows(positions, span), span // 2 if anchor is None else anchor, left, right)


def sliding_windows(positions: np.ndarray, span: int) -> np.ndarray:
    """Every window of ``span`` consecutive frames of ``(T, ...)`` values as ``(T - span + 1, span, ...)`` (a copy)."""
    p = np.asarray(positions, dtype=np.float64)
    n = len(p) - span + 1
    if n < 1:
        raise DataError(f"windows of {span} frames need at least {span} frames; got {len(p)}")
    return np.stack([p[k : k + n] for k in range(span)], axis=1)
