"""Differentiable torch rotations and forward kinematics, for models that need gradients.

Conventions match :mod:`dance_core.motion.rotations`: scalar-last quaternions, matrices acting on
column vectors, 6D = the first two matrix columns.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch


def sixd_to_matrix(d: torch.Tensor) -> torch.Tensor:
    """``(..., 6)`` to rotation matrices ``(..., 3, 3)`` by Gram-Schmidt."""
    a = torch.nn.functional.normalize(d[..., :3], dim=-1)
    b = d[..., 3:] - (a * d[..., 3:]).sum(-1, keepdim=True) * a
    b = torch.nn.functional.normalize(b, dim=-1)
    return torch.stack([a, b, torch.cross(a, b, dim=-1)], dim=-1)


def matrix_to_6d(m: torch.Tensor) -> torch.Tensor:
    """Rotation matrices to the 6D representation."""
    return torch.cat([m[..., :, 0], m[..., :, 1]], dim=-1)


def expmap_to_matrix(r: torch.Tensor) -> torch.Tensor:
    """Exponential maps ``(..., 3)`` to matrices by Rodrigues' formula (smooth at zero)."""
    theta2 = (r * r).sum(-1, keepdim=True)
    theta = torch.sqrt(theta2 + 1e-24)
    small = theta2 < 1e-8
    a = torch.where(small, 1 - theta2 / 6, torch.sin(theta) / theta)
    b = torch.where(small, 0.5 - theta2 / 24, (1 - torch.cos(theta)) / torch.clamp(theta2, min=1e-24))
    x, y, z = r.unbind(-1)
    zero = torch.zeros_like(x)
    k = torch.stack([zero, -z, y, z, zero, -x, -y, x, zero], -1).reshape(*r.shape[:-1], 3, 3)
    eye = torch.eye(3, dtype=r.dtype, device=r.device).expand_as(k)
    return eye + a[..., None] * k + b[..., None] * (k @ k)


def quat_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """Quaternions ``(..., 4)`` (normalized here) to matrices."""
    x, y, z, w = torch.nn.functional.normalize(q, dim=-1).unbind(-1)
    return torch.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
    ], -1).reshape(*q.shape[:-1], 3, 3)


def forward_kinematics(
    parents: Sequence[int], offsets: torch.Tensor, root: torch.Tensor, rotations: torch.Tensor
) -> torch.Tensor:
    """World joint positions ``(..., J, 3)`` from local rotation matrices ``(..., J, 3, 3)``,
    root positions ``(..., 3)`` and offsets ``(J, 3)`` (parents in depth-first order)."""
    world_r = [rotations[..., 0, :, :]]
    world_p = [root]
    for j in range(1, len(parents)):
        p = parents[j]
        world_r.append(world_r[p] @ rotations[..., j, :, :])
        world_p.append(world_p[p] + (world_r[p] @ offsets[j].to(rotations.dtype)[:, None])[..., 0])
    return torch.stack(world_p, dim=-2)
