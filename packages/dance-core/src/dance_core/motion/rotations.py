"""NumPy rotation conversions (via ``scipy.spatial.transform``) and time-continuity fixes.

Quaternions are scalar-last ``(x, y, z, w)``. Axis-angle and exponential map are the same vector
(axis times angle in radians); :func:`unroll_expmap` keeps a sequence of them continuous. Euler
angles follow BVH: an order like ``"ZXY"`` means ``R = Rz @ Rx @ Ry`` (intrinsic), in degrees.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from dance_core.errors import DataError

KINDS = {"quat": 4, "expmap": 3, "axis-angle": 3, "6d": 6, "matrix": 9}


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` quaternions to ``(..., 3, 3)`` matrices."""
    q = np.asarray(q, dtype=np.float64)
    return Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(*q.shape[:-1], 3, 3)


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` matrices to unit quaternions ``(..., 4)`` with ``w >= 0``."""
    m = np.asarray(m, dtype=np.float64)
    q = Rotation.from_matrix(m.reshape(-1, 3, 3)).as_quat(canonical=True)
    return q.reshape(*m.shape[:-2], 4)


def quat_to_expmap(q: np.ndarray) -> np.ndarray:
    """Quaternions to exponential maps (angle in ``[0, pi]``)."""
    q = np.asarray(q, dtype=np.float64)
    return Rotation.from_quat(q.reshape(-1, 4)).as_rotvec().reshape(*q.shape[:-1], 3)


def expmap_to_quat(r: np.ndarray) -> np.ndarray:
    """Exponential maps (any angle) to quaternions."""
    r = np.asarray(r, dtype=np.float64)
    return Rotation.from_rotvec(r.reshape(-1, 3)).as_quat().reshape(*r.shape[:-1], 4)


def matrix_to_6d(m: np.ndarray) -> np.ndarray:
    """The continuous 6D representation: the first two columns of the matrix, ``(..., 6)``."""
    m = np.asarray(m, dtype=np.float64)
    return np.concatenate([m[..., :, 0], m[..., :, 1]], axis=-1)


def sixd_to_matrix(d: np.ndarray) -> np.ndarray:
    """6D back to a rotation matrix by Gram-Schmidt (exact for a valid 6D vector)."""
    d = np.asarray(d, dtype=np.float64)
    a = d[..., :3] / np.maximum(np.linalg.norm(d[..., :3], axis=-1, keepdims=True), 1e-12)
    b = d[..., 3:] - (a * d[..., 3:]).sum(-1, keepdims=True) * a
    b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
    return np.stack([a, b, np.cross(a, b)], axis=-1)


def check_order(order: str) -> str:
    """A BVH rotation order such as ``"ZXY"`` (three distinct axes), upper-cased."""
    o = order.upper()
    if len(o) != 3 or set(o) != set("XYZ"):
        raise DataError(f"rotation order {order!r} is not a permutation of XYZ")
    return o


def euler_to_quat(angles: np.ndarray, order: str) -> np.ndarray:
    """BVH Euler angles in degrees ``(..., 3)`` (in channel order) to quaternions."""
    a = np.asarray(angles, dtype=np.float64)
    return Rotation.from_euler(check_order(order), a.reshape(-1, 3), degrees=True).as_quat().reshape(*a.shape[:-1], 4)


def quat_to_euler(q: np.ndarray, order: str, continuous: bool = True) -> np.ndarray:
    """Quaternions ``(T, ..., 4)`` to BVH Euler degrees; ``continuous`` removes 360° and 180° flips over time."""
    q = np.asarray(q, dtype=np.float64)
    import warnings

    with warnings.catch_warnings():  # gimbal lock is handled, and the result is still exact
        warnings.simplefilter("ignore", UserWarning)
        e = Rotation.from_quat(q.reshape(-1, 4)).as_euler(check_order(order), degrees=True)
    e = e.reshape(*q.shape[:-1], 3)
    return unroll_euler(e) if continuous and e.ndim >= 2 else e


def unroll_euler(e: np.ndarray) -> np.ndarray:
    """Along axis 0, pick per frame the equivalent Euler triple closest to the previous frame.

    For intrinsic Tait-Bryan angles ``(a, b, c)`` equals ``(a + 180, 180 - b, c + 180)``, and each angle
    may shift by multiples of 360; choosing the nearest keeps curves free of jumps.
    """
    e = np.array(e, dtype=np.float64)
    for t in range(1, len(e)):
        prev = e[t - 1]
        alt = np.stack([e[t], np.stack([e[t, ..., 0] + 180, 180 - e[t, ..., 1], e[t, ..., 2] + 180], -1)])
        alt = alt - 360.0 * np.round((alt - prev) / 360.0)
        cost = np.abs(alt - prev).sum(-1)
        pick = np.argmin(cost, axis=0)
        e[t] = np.take_along_axis(alt, pick[None, ..., None], axis=0)[0]
    return e


def unroll_expmap(r: np.ndarray) -> np.ndarray:
    """Along axis 0, replace ``theta * axis`` by ``(theta - 2 pi) * axis`` when that is closer to the
    previous frame, so exponential maps stay continuous through the ``pi`` boundary."""
    r = np.array(r, dtype=np.float64)
    for t in range(1, len(r)):
        theta = np.linalg.norm(r[t], axis=-1, keepdims=True)
        axis = r[t] / np.maximum(theta, 1e-12)
        cands = [r[t], r[t] - 2 * np.pi * axis, r[t] + 2 * np.pi * axis]
        dist = np.stack([np.linalg.norm(c - r[t - 1], axis=-1) for c in cands])
        pick = np.argmin(dist, axis=0)
        r[t] = np.choose(pick[..., None], cands)
    return r


def unroll_quat(q: np.ndarray) -> np.ndarray:
    """Along axis 0, flip signs so consecutive quaternions lie in the same hemisphere."""
    q = np.array(q, dtype=np.float64)
    for t in range(1, len(q)):
        flip = (q[t] * q[t - 1]).sum(-1) < 0
        q[t][flip] *= -1
    return q


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of scalar-last quaternions (broadcasting)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion)."""
    q = np.array(q, dtype=np.float64)
    q[..., :3] *= -1
    return q


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by quaternions ``q (..., 4)`` (broadcasting)."""
    q = np.asarray(q, np.float64)
    u, w = q[..., :3], q[..., 3:]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of 3-vectors (broadcasting), the same arithmetic without its axis bookkeeping, which
    costs more than the products on the few vectors of one frame (forward kinematics joint by joint)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def quat_slerp(q0: np.ndarray, q1: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Spherical interpolation from unit quaternions ``q0`` to ``q1`` (``(..., 4)``, scalar-last) by
    fractions ``w`` broadcasting against ``q0[..., :1]``, along the shorter arc."""
    q0, q1 = np.asarray(q0, np.float64), np.asarray(q1, np.float64)
    dot = (q0 * q1).sum(-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    theta = np.arccos(np.clip(np.abs(dot), 0.0, 1.0))
    w = np.asarray(w, np.float64)
    sin = np.sin(theta)
    near = sin < 1e-8  # (almost) the same rotation: interpolate linearly and renormalize
    safe = np.where(near, 1.0, sin)
    a = np.where(near, 1.0 - w, np.sin((1.0 - w) * theta) / safe)
    b = np.where(near, w, np.sin(w * theta) / safe)
    q = a * q0 + b * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def yaw_quat(angle: np.ndarray) -> np.ndarray:
    """Quaternions of rotations by ``angle`` radians about +Y."""
    a = np.asarray(angle, np.float64) / 2
    z = np.zeros_like(a)
    return np.stack([z, np.sin(a), z, np.cos(a)], axis=-1)


def to_kind(q: np.ndarray, kind: str) -> np.ndarray:
    """Quaternions ``(T, J, 4)`` to a representation ``(T, J, width)``, continuous over time."""
    if kind == "quat":
        return unroll_quat(q)
    if kind in ("expmap", "axis-angle"):
        return unroll_expmap(quat_to_expmap(q))
    m = quat_to_matrix(q)
    if kind == "6d":
        return matrix_to_6d(m)
    if kind == "matrix":
        return m.reshape(*m.shape[:-2], 9)
    raise DataError(f"unknown rotation kind {kind!r}; known: {', '.join(KINDS)}")


def from_kind(x: np.ndarray, kind: str) -> np.ndarray:
    """Inverse of :func:`to_kind`: ``(T, J, width)`` to unit quaternions (projecting onto rotations)."""
    x = np.asarray(x, np.float64)
    if kind == "quat":
        return x / np.maximum(np.linalg.norm(x, axis=-1, keepdims=True), 1e-12)
    if kind in ("expmap", "axis-angle"):
        return expmap_to_quat(x)
    if kind == "6d":
        return matrix_to_quat(sixd_to_matrix(x))
    if kind == "matrix":
        m = x.reshape(*x.shape[:-1], 3, 3)
        u, _, vt = np.linalg.svd(m)
        det = np.sign(np.linalg.det(u @ vt))
        u[..., :, -1] *= det[..., None]
        return matrix_to_quat(u @ vt)
    raise DataError(f"unknown rotation kind {kind!r}; known: {', '.join(KINDS)}")
