"""Motion representations: skeletal motion to per-frame feature arrays ``(T, D)`` for models, and back.

A recipe picks one under ``motion:``; its name and options, and the training skeleton, are stored in
the checkpoint so ``dance compose`` can decode generated features into BVH files and previews.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.root import DELTA_CHANNELS, deltas_to_root, root_to_deltas
from dance_core.motion.rotations import KINDS, from_kind, to_kind
from dance_core.motion.skeleton import Skeleton

_COMPONENTS = {"quat": "xyzw", "expmap": "xyz", "6d": ("a1", "a2", "a3", "b1", "b2", "b3")}


class RotationRepresentation:
    """Root channels (deltas or absolute position) followed by one rotation per kept joint."""

    def __init__(self, rotation: str = "expmap", root: str = "deltas", joints: list[str] | None = None):
        self.rotation, self.root, self.joints = rotation, root, joints
        self.width = KINDS[rotation]

    def _kept(self, skeleton: Skeleton) -> list[int]:
        if self.joints is None:
            return list(range(len(skeleton)))
        kept = [skeleton.index(n) for n in self.joints]
        if 0 not in kept:
            raise DataError(f"motion.joints must include the root joint {skeleton.names[0]!r}")
        return sorted(kept)

    def channels(self, skeleton: Skeleton) -> list[str]:
        """Channel names, e.g. ``root.dx ... Hips.rot.x ...``."""
        root = list(DELTA_CHANNELS) if self.root == "deltas" else ["root.x", "root.y", "root.z"]
        comps = _COMPONENTS.get(self.rotation) or [str(i) for i in range(self.width)]
        return root + [f"{skeleton.names[j]}.{self.rotation}.{c}" for j in self._kept(skeleton) for c in comps]

    def dim(self, skeleton: Skeleton) -> int:
        """Feature width on a skeleton."""
        return len(self.channels(skeleton))

    def encode(self, motion: Motion) -> np.ndarray:
        """``(T, D)`` float32 features of a motion with rotations."""
        if motion.rotations is None:
            raise DataError("motion representation 'rotations' needs joint rotations; this motion has only positions")
        rot = motion.rotations.copy()
        if self.root == "deltas":
            root, rot[:, 0], _ = root_to_deltas(motion.root, rot[:, 0])
        else:
            root = motion.root
        rot = to_kind(rot[:, self._kept(motion.skeleton)], self.rotation)
        return np.concatenate([root, rot.reshape(len(rot), -1)], axis=1).astype(np.float32)

    def decode(self, values: np.ndarray, skeleton: Skeleton, fps: float) -> Motion:
        """Features back to a motion (deltas are integrated from the origin, facing +Z)."""
        values = np.asarray(values, np.float64)
        n_root = 4 if self.root == "deltas" else 3
        kept = self._kept(skeleton)
        if values.shape[1] != n_root + len(kept) * self.width:
            raise DataError(f"motion features have {values.shape[1]} channels; the representation needs "
                            f"{n_root + len(kept) * self.width} on skeleton {skeleton.name}")
        rot = np.zeros((len(values), len(skeleton), 4))
        rot[..., 3] = 1.0
        rot[:, kept] = from_kind(values[:, n_root:].reshape(len(values), len(kept), self.width), self.rotation)
        if self.root == "deltas":
            root, rot[:, 0] = deltas_to_root(values[:, :4], rot[:, 0])
        else:
            root = values[:, :3]
        return Motion(skeleton, fps, root, rot)


class PositionRepresentation:
    """Joint positions relative to the root's ground point, after root channels
    (``dx, dz, y`` ground deltas in world axes, or absolute ``x, y, z``)."""

    def __init__(self, dims: int = 3, root: str = "deltas"):
        self.dims, self.root = dims, root

    def channels(self, skeleton: Skeleton) -> list[str]:
        """Channel names."""
        root = ["root.dx", "root.dz", "root.y"] if self.root == "deltas" else ["root.x", "root.y", "root.z"]
        return root + [f"{n}.{a}" for n in skeleton.names for a in "xyz"[: self.dims]]

    def dim(self, skeleton: Skeleton) -> int:
        """Feature width on a skeleton."""
        return len(self.channels(skeleton))

    def encode(self, motion: Motion) -> np.ndarray:
        """``(T, D)`` float32 features."""
        pos = motion.positions()
        ground = motion.root * np.array([1.0, 0.0, 1.0])
        rel = (pos - ground[:, None, :])[..., : self.dims]
        if self.root == "deltas":
            d = np.zeros((len(pos), 3))
            d[1:, 0], d[1:, 1] = np.diff(motion.root[:, 0]), np.diff(motion.root[:, 2])
            d[:, 2] = motion.root[:, 1]
        else:
            d = motion.root
        return np.concatenate([d, rel.reshape(len(pos), -1)], axis=1).astype(np.float32)

    def decode(self, values: np.ndarray, skeleton: Skeleton, fps: float) -> Motion:
        """Features back to a positions-only motion."""
        values = np.asarray(values, np.float64)
        if values.shape[1] != self.dim(skeleton):
            raise DataError(f"motion features have {values.shape[1]} channels; {self.dim(skeleton)} expected")
        if self.root == "deltas":
            root = np.stack([np.cumsum(values[:, 0]), values[:, 2], np.cumsum(values[:, 1])], axis=1)
        else:
            root = values[:, :3]
        rel = values[:, 3:].reshape(len(values), len(skeleton), self.dims)
        if self.dims == 2:
            rel = np.concatenate([rel, np.zeros(rel.shape[:2] + (1,))], axis=-1)
        pos = rel + (root * np.array([1.0, 0.0, 1.0]))[:, None, :]
        return Motion(skeleton, fps, root, joint_positions=pos)


def build_rotations(config: Any, **_: Any) -> RotationRepresentation:
    """Build the ``rotations`` representation."""
    return RotationRepresentation(config.rotation, config.root, config.joints)


def build_positions(config: Any, **_: Any) -> PositionRepresentation:
    """Build the ``positions`` representation."""
    return PositionRepresentation(config.dims, config.root)
