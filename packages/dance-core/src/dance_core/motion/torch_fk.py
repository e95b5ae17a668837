"""Differentiable forward kinematics in torch, and joint positions of a standardized ``rotations`` motion.

The same arithmetic as :mod:`dance_core.motion.fk` (scalar-last quaternions, one depth of the tree at a
time), in torch so a training loss can see the joints' positions of a decoded motion: a foot's height is
one number here, while in the ``rotations`` representation it is spread over the hips', knees' and
ankles' rotations and the root's height.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from dance_core.errors import DataError
from dance_core.motion.fk import _levels
from dance_core.motion.skeleton import Skeleton

#: the rotation kinds of the ``rotations`` representation whose joint positions this module computes
SUPPORTED = ("expmap", "axis-angle", "quat")


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product ``a * b`` of scalar-last quaternions (broadcasting)."""
    ax, ay, az, aw = a.unbind(-1)
    bx, by, bz, bw = b.unbind(-1)
    return torch.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], dim=-1)


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)`` (broadcasting)."""
    u, w = q[..., :3], q[..., 3:]
    t = 2.0 * torch.linalg.cross(u, v.expand_as(u), dim=-1)
    return v + w * t + torch.linalg.cross(u, t, dim=-1)


def expmap_to_quat(r: torch.Tensor) -> torch.Tensor:
    """Exponential maps ``(..., 3)`` (axis times angle) to unit quaternions ``(..., 4)``; smooth at angle 0."""
    theta2 = (r * r).sum(-1, keepdim=True)
    theta = torch.sqrt(theta2.clamp_min(1e-12))
    small = theta2 < 1e-6
    # sin(theta / 2) / theta, by its Taylor series near 0 (where the division loses its gradient)
    scale = torch.where(small, 0.5 - theta2 / 48.0, torch.sin(theta / 2) / theta)
    w = torch.where(small, 1.0 - theta2 / 8.0, torch.cos(theta / 2))
    return torch.cat([r * scale, w], dim=-1)


def forward_kinematics(skeleton: Skeleton, root: torch.Tensor, rotations: torch.Tensor) -> torch.Tensor:
    """World positions ``(..., J, 3)`` of local rotations ``(..., J, 4)`` with the root joint at ``root (..., 3)``
    (as :func:`dance_core.motion.fk.forward_kinematics`, positions only)."""
    offsets = torch.as_tensor(skeleton.offsets, dtype=rotations.dtype, device=rotations.device)
    world_r = [None] * len(skeleton)
    world_p = [None] * len(skeleton)
    world_r[0], world_p[0] = rotations[..., 0, :], root
    for joints, parents in _levels(tuple(int(p) for p in skeleton.parents)):
        pr = torch.stack([world_r[p] for p in parents], dim=-2)
        pp = torch.stack([world_p[p] for p in parents], dim=-2)
        r = quat_mul(pr, rotations[..., joints, :])
        p = pp + quat_rotate(pr, offsets[joints])
        for i, j in enumerate(joints):
            world_r[j], world_p[j] = r[..., i, :], p[..., i, :]
    return torch.stack(world_p, dim=-2)


class RotationKinematics:
    """Joint positions ``(B, T, J, 3)`` of standardized ``rotations`` features ``(B, T, D)`` (expmap,
    axis-angle or quaternion rotations), in the body's own frame: with ``root: deltas`` the root stands at
    ``(0, y, 0)`` facing +Z in every frame (its ground travel and heading, which deltas carry, left out);
    with absolute roots at its position. Heights are world heights either way."""

    def __init__(self, skeleton: Skeleton, options: dict[str, Any], mean: np.ndarray, std: np.ndarray):
        self.skeleton, self.names = skeleton, list(skeleton.names)
        self.rotation, self.root = options.get("rotation", "expmap"), options.get("root", "deltas")
        if self.rotation not in SUPPORTED:
            raise DataError(f"joint positions in torch: rotation {self.rotation!r} is not supported "
                            "(expmap, axis-angle, quat)")
        joints = options.get("joints")
        self.kept = list(range(len(skeleton))) if joints is None else sorted(skeleton.index(n) for n in joints)
        self.width = 4 if self.rotation == "quat" else 3
        self.n_root = 4 if self.root == "deltas" else 3
        if len(mean) != self.n_root + len(self.kept) * self.width:
            raise DataError(f"joint positions in torch: {len(mean)} motion channels, the representation has "
                            f"{self.n_root + len(self.kept) * self.width}")
        self.mean, self.std = np.asarray(mean, np.float32), np.asarray(std, np.float32)
        self._device: dict[tuple, tuple[torch.Tensor, torch.Tensor]] = {}

    @classmethod
    def from_info(cls, info: Any, stats: Any) -> RotationKinematics | None:
        """From a ``MotionInfo`` and the motion's ``Standardizer``; None unless the motion is ``rotations`` with
        rotations this module reads (``SUPPORTED``)."""
        if getattr(info, "representation", None) != "rotations" or info.skeleton is None:
            return None
        if dict(info.options).get("rotation", "expmap") not in SUPPORTED:
            return None
        return cls(info.skeleton, dict(info.options), stats.mean, stats.std)

    def _stats(self, like: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        key = (like.device, like.dtype)
        if key not in self._device:
            self._device[key] = (torch.as_tensor(self.mean, dtype=like.dtype, device=like.device),
                                 torch.as_tensor(self.std, dtype=like.dtype, device=like.device))
        return self._device[key]

    def __call__(self, features: torch.Tensor) -> torch.Tensor:
        """Joint positions ``(..., T, J, 3)`` of standardized features ``(..., T, D)``."""
        mean, std = self._stats(features)
        x = features * std + mean
        lead = x.shape[:-1]
        values = x[..., self.n_root:].reshape(*lead, len(self.kept), self.width)
        if self.rotation == "quat":
            local = values / values.norm(dim=-1, keepdim=True).clamp_min(1e-8)
        else:
            local = expmap_to_quat(values)
        if len(self.kept) == len(self.skeleton):
            rotations = local
        else:
            identity = x.new_zeros(*lead, len(self.skeleton), 4)
            identity[..., 3] = 1.0
            rotations = identity.index_copy(-2, torch.tensor(self.kept, device=x.device), local)
        if self.root == "deltas":
            zero = torch.zeros_like(x[..., 2:3])
            root = torch.cat([zero, x[..., 2:3], zero], dim=-1)
        else:
            root = x[..., :3]
        return forward_kinematics(self.skeleton, root, rotations)
