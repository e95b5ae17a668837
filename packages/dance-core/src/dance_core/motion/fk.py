"""Batched forward kinematics in NumPy: local rotations and root positions to world joint positions."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from dance_core.motion.rotations import quat_mul, quat_rotate
from dance_core.motion.skeleton import Skeleton

#: batches of at most this many frames find positions through rotation matrices: a product per joint level
#: where quaternions take a dozen NumPy calls, about 4x faster for one frame (``dance live`` poses frame by
#: frame); larger batches through quaternions, whose elementwise products beat NumPy's small matrix products
MATRIX_FRAMES = 64


def forward_kinematics(
    skeleton: Skeleton, root: np.ndarray, rotations: np.ndarray, offsets: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """World positions ``(..., J, 3)`` and world rotations ``(..., J, 4)``.

    ``root (..., 3)`` is the root joint's world position; ``rotations (..., J, 4)`` are local
    quaternions (each joint relative to its parent); ``offsets`` overrides the skeleton's.
    """
    rotations = np.asarray(rotations, np.float64)
    offsets = skeleton.offsets if offsets is None else np.asarray(offsets, np.float64)
    world_r = np.empty_like(rotations)
    world_p = np.empty(rotations.shape[:-1] + (3,))
    world_r[..., 0, :] = rotations[..., 0, :]
    world_p[..., 0, :] = root
    for joints, parents in _levels(tuple(int(p) for p in skeleton.parents)):  # all joints of one depth at once
        world_r[..., joints, :] = quat_mul(world_r[..., parents, :], rotations[..., joints, :])
        world_p[..., joints, :] = world_p[..., parents, :] + quat_rotate(world_r[..., parents, :], offsets[joints])
    return world_p, world_r


def joint_positions(skeleton: Skeleton, root: np.ndarray, rotations: np.ndarray, end_sites: bool = False
                    ) -> np.ndarray:
    """World positions ``(..., J, 3)`` of :func:`forward_kinematics`, with the End Sites' appended (in
    ``end_sites`` key order) when asked; batches of at most :data:`MATRIX_FRAMES` frames through rotation
    matrices (the same positions to rounding)."""
    rotations = np.asarray(rotations, np.float64)
    joints = rotations.shape[-2]
    if rotations.size > MATRIX_FRAMES * joints * 4:
        pos, world = forward_kinematics(skeleton, root, rotations)
        return np.concatenate([pos, end_site_positions(skeleton, pos, world)], axis=-2) if end_sites else pos
    local = _rotation_matrices(rotations)
    world = np.empty_like(local)
    pos = np.empty(rotations.shape[:-1] + (3,))
    world[..., 0, :, :] = local[..., 0, :, :]
    pos[..., 0, :] = root
    offsets = skeleton.offsets
    for children, parents in _levels(tuple(int(p) for p in skeleton.parents)):
        above = world[..., parents, :, :]
        world[..., children, :, :] = above @ local[..., children, :, :]
        pos[..., children, :] = pos[..., parents, :] + (above @ offsets[children][..., None])[..., 0]
    if not end_sites:
        return pos
    keys = sorted(skeleton.end_sites)
    tips = np.array([skeleton.end_sites[j] for j in keys], np.float64).reshape(-1, 3, 1)
    return np.concatenate([pos, pos[..., keys, :] + (world[..., keys, :, :] @ tips)[..., 0]], axis=-2)


def _rotation_matrices(q: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` matrices ``M`` with ``M v == quat_rotate(q, v)``: the rotation of a unit quaternion, the
    same arithmetic for any other (nothing normalized, so a malformed one cannot raise where the quaternion
    path would not)."""
    x, y, z, w = (q[..., k] for k in range(4))
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    m[..., 2, 0], m[..., 2, 1], m[..., 2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return m


@lru_cache(maxsize=64)
def _levels(parents: tuple[int, ...]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The joints below the root grouped by depth, each group with its parents: ``[(joints, parents)]``."""
    depth = [0] * len(parents)
    for j in range(1, len(parents)):
        depth[j] = depth[parents[j]] + 1
    out = []
    for d in range(1, max(depth, default=0) + 1):
        joints = np.array([j for j in range(len(parents)) if depth[j] == d])
        out.append((joints, np.array([parents[j] for j in joints])))
    return out


def end_site_positions(skeleton: Skeleton, positions: np.ndarray, world_rotations: np.ndarray) -> np.ndarray:
    """World positions ``(..., E, 3)`` of the skeleton's End Sites (in ``end_sites`` key order)."""
    keys = sorted(skeleton.end_sites)
    if not keys:
        return np.zeros(positions.shape[:-2] + (0, 3))
    return np.stack(
        [positions[..., j, :] + quat_rotate(world_rotations[..., j, :], skeleton.end_sites[j]) for j in keys], axis=-2
    )
