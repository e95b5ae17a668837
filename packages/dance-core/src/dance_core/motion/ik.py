"""Analytic two-bone inverse kinematics (hip–knee–ankle) on world rotations, vectorised over frames.

The solver returns *corrections*: world-space rotations to apply at the upper and the middle joint.
When the end joint already sits on its target both are the identity (to rounding), so frames that
need nothing are left as they were.
"""

from __future__ import annotations

import numpy as np

from dance_core.motion.rotations import quat_rotate

_EPS = 1e-9


def axis_angle_quat(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternions ``(..., 4)`` of rotations by ``angle`` about unit ``axis (..., 3)``."""
    half = np.asarray(angle, np.float64)[..., None] / 2
    return np.concatenate([axis * np.sin(half), np.cos(half)], axis=-1)


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The shortest-arc quaternions ``(..., 4)`` turning direction ``a`` into direction ``b``."""
    a = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), _EPS)
    b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), _EPS)
    q = np.concatenate([np.cross(a, b), 1.0 + (a * b).sum(-1, keepdims=True)], axis=-1)
    # opposite directions: a half turn about any axis perpendicular to a
    opposite = q[..., 3] < 1e-8
    if np.any(opposite):
        helper = np.where(np.abs(a[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        perp = np.cross(a, helper)
        perp /= np.linalg.norm(perp, axis=-1, keepdims=True)
        q[opposite] = np.concatenate([perp, np.zeros(perp.shape[:-1] + (1,))], axis=-1)[opposite]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def two_bone_ik(
    upper: np.ndarray, middle: np.ndarray, end: np.ndarray, target: np.ndarray, bend_hint: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World rotations ``(q_upper, q_middle)`` (each ``(..., 4)``) that bring ``end`` onto ``target``.

    ``upper``, ``middle``, ``end`` are the world positions of e.g. hip, knee and ankle. First the
    middle joint's angle is opened or closed about the limb's own bend axis (``bend_hint``, the
    direction the middle joint should move to, serves when the limb is straight) until the
    upper–end distance equals the upper–target distance (clamped to what the bones can reach);
    then the whole limb swings about the upper joint onto the target by the shortest arc.
    Apply ``q_middle`` to the middle joint's world rotation first, then ``q_upper`` to both:
    ``R_upper' = q_upper R_upper``, ``R_middle' = q_upper q_middle R_middle``.
    """
    u = upper - middle
    v = end - middle
    a = np.linalg.norm(u, axis=-1)
    b = np.linalg.norm(v, axis=-1)
    d = np.linalg.norm(target - upper, axis=-1)
    d = np.clip(d, np.abs(a - b) + 1e-6 * (a + b), (a + b) * (1 - 1e-6))
    axis = np.cross(u, v)
    sin_now = np.linalg.norm(axis, axis=-1)
    angle_now = np.arctan2(sin_now, (u * v).sum(-1))
    # a straight limb: bend so that the middle joint moves towards the hint
    fallback = np.cross(v, bend_hint)
    straight = sin_now < 1e-6 * np.maximum(a * b, _EPS)
    axis = np.where(straight[..., None], fallback, axis)
    axis = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), _EPS)
    cos_goal = np.clip((a * a + b * b - d * d) / np.maximum(2 * a * b, _EPS), -1.0, 1.0)
    q_middle = axis_angle_quat(axis, np.arccos(cos_goal) - angle_now)
    reached = middle + quat_rotate(q_middle, v)
    q_upper = rotation_between(reached - upper, target - upper)
    return q_upper, q_middle

