"""Batched forward kinematics in NumPy: local rotations and root positions to world joint positions."""

from __future__ import annotations

import numpy as np

from dance_core.motion.rotations import quat_mul, quat_rotate
from dance_core.motion.skeleton import Skeleton


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
    for j in range(1, len(skeleton)):
        p = skeleton.parents[j]
        world_r[..., j, :] = quat_mul(world_r[..., p, :], rotations[..., j, :])
        world_p[..., j, :] = world_p[..., p, :] + quat_rotate(world_r[..., p, :], offsets[j])
    return world_p, world_r


def end_site_positions(skeleton: Skeleton, positions: np.ndarray, world_rotations: np.ndarray) -> np.ndarray:
    """World positions ``(..., E, 3)`` of the skeleton's End Sites (in ``end_sites`` key order)."""
    keys = sorted(skeleton.end_sites)
    if not keys:
        return np.zeros(positions.shape[:-2] + (0, 3))
    return np.stack(
        [positions[..., j, :] + quat_rotate(world_rotations[..., j, :], skeleton.end_sites[j]) for j in keys], axis=-2
    )
