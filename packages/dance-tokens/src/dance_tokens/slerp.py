"""TM2D's editing baseline (section 4.1): a text-driven motion spliced into a music-driven dance.

"[Slerp] aligns the last generated frame of the dance with the first frame of the motion by text with
a transition window of 10 frames, and applies spherical interpolation of quaternion to fill in the
transition in between." Here the dance runs up to ``start``; over ``transition`` frames every joint's
local rotation is slerped, and the root position linearly interpolated, to the first frame of the
clip, which is placed where (and, with ``align_facing``, facing where) the dancer stands; the clip
plays; a second transition returns to the dance, which resumes at the frame that time has reached,
moved on the floor to continue from where the clip ended. Motions are skeletal, Y up.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from dance_core import DataError, Motion, quat_slerp

UP = np.array([0.0, 1.0, 0.0])
GROUND = np.array([1.0, 0.0, 1.0])


def slerp(q0: np.ndarray, q1: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Spherical interpolation of unit quaternions ``(..., 4)`` (scalar-last) at fractions ``w (n,)``,
    along the shorter arc: ``(n, ..., 4)`` (core's :func:`~dance_core.quat_slerp`)."""
    q0 = np.asarray(q0, np.float64)
    return quat_slerp(q0[None], np.asarray(q1, np.float64)[None],
                      np.asarray(w, np.float64).reshape((-1,) + (1,) * q0.ndim))


def heading(root_rotation: np.ndarray) -> np.ndarray:
    """Yaw (radians about +Y) of the direction the root's local +Z faces, per quaternion ``(..., 4)``."""
    forward = Rotation.from_quat(np.asarray(root_rotation).reshape(-1, 4)).apply([0.0, 0.0, 1.0])
    return np.arctan2(forward[:, 0], forward[:, 2]).reshape(np.shape(root_rotation)[:-1])


def placed(clip: Motion, position: np.ndarray, yaw: float | None) -> Motion:
    """``clip`` moved on the floor so its first frame stands at ``position`` (x, z) and, when ``yaw`` is
    given, turned about the vertical so its first frame faces ``yaw``."""
    root, rotations = clip.root.copy(), clip.rotations.copy()
    if yaw is not None:
        turn = Rotation.from_rotvec(UP * (yaw - heading(rotations[0, 0])))
        root = root[0] + turn.apply(root - root[0])
        rotations[:, 0] = (turn * Rotation.from_quat(rotations[:, 0])).as_quat()
    root += (np.asarray(position) - root[0]) * GROUND
    return replace(clip, root=root, rotations=rotations)


def slerp_splice(
    dance: Motion, clip: Motion, start: int, transition: int = 10, align_facing: bool = True
) -> Motion:
    """``dance`` with ``clip`` spliced in at frame ``start`` through ``transition``-frame slerp
    transitions on either side; as long as ``dance`` (the end is cut when the splice runs past it)."""
    if dance.rotations is None or clip.rotations is None:
        raise DataError("slerp_splice: both motions need joint rotations (skeletal motion)")
    if clip.skeleton.names != dance.skeleton.names:
        clip = clip.conformed(dance.skeleton, "slerp_splice: clip")
    if abs(clip.fps - dance.fps) > 1e-9:
        clip = clip.resample(dance.fps)
    n = dance.n_frames
    if not 1 <= start < n:
        raise DataError(f"slerp_splice: start ({start}) must fall inside the dance (1..{n - 1})")
    if transition < 0:
        raise DataError(f"slerp_splice: transition must be >= 0 frames, got {transition}")
    before = start - 1
    yaw = float(heading(dance.rotations[before, 0])) if align_facing else None
    clip = placed(clip, dance.root[before], yaw)
    resume = min(start + 2 * transition + clip.n_frames, n - 1)
    after_root = dance.root[resume:] + (clip.root[-1] - dance.root[resume]) * GROUND
    w = np.arange(1, transition + 1) / (transition + 1)

    def bridge(root0, rot0, root1, rot1):
        return root0 + w[:, None] * (root1 - root0), slerp(rot0, rot1, w)

    in_root, in_rot = bridge(dance.root[before], dance.rotations[before], clip.root[0], clip.rotations[0])
    out_root, out_rot = bridge(clip.root[-1], clip.rotations[-1], after_root[0], dance.rotations[resume])
    root = np.concatenate([dance.root[:start], in_root, clip.root, out_root, after_root])[:n]
    rotations = np.concatenate([dance.rotations[:start], in_rot, clip.rotations, out_rot,
                                dance.rotations[resume:]])[:n]
    return replace(dance, root=root, rotations=rotations)
