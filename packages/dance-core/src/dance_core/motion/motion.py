"""The motion container: a skeleton, a frame rate, root positions and local joint rotations.

Positions come on demand through forward kinematics. Data that only has joint positions (HumanML3D
``new_joints``, 2D keypoints) is held as ``joint_positions`` with ``rotations=None``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.fk import joint_positions
from dance_core.motion.skeleton import Skeleton


@dataclass
class Motion:
    """``root (T, 3)`` world root positions, ``rotations (T, J, 4)`` local quaternions (or None with
    ``joint_positions (T, J, 3)``), on ``skeleton`` at ``fps``."""

    skeleton: Skeleton
    fps: float
    root: np.ndarray
    rotations: np.ndarray | None = None
    joint_positions: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        self.root = np.asarray(self.root, np.float64).reshape(-1, 3)
        t, j = len(self.root), len(self.skeleton)
        if self.rotations is not None:
            self.rotations = np.asarray(self.rotations, np.float64)
            if self.rotations.shape != (t, j, 4):
                raise DataError(f"motion: rotations {self.rotations.shape}, expected {(t, j, 4)}")
        elif self.joint_positions is not None:
            self.joint_positions = np.asarray(self.joint_positions, np.float64)
            if self.joint_positions.shape[:2] != (t, j):
                raise DataError(f"motion: joint positions {self.joint_positions.shape}, expected ({t}, {j}, 3)")
        else:
            raise DataError("motion: needs rotations or joint positions")
        if not (self.fps > 0):
            raise DataError(f"motion: fps must be positive, got {self.fps}")

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return len(self.root)

    @property
    def duration(self) -> float:
        """Seconds covered: ``n_frames / fps`` (frame i describes time i / fps)."""
        return self.n_frames / self.fps

    def positions(self, end_sites: bool = False) -> np.ndarray:
        """World joint positions ``(T, J, 3)`` (with End Sites appended when asked)."""
        if self.rotations is None:
            return self.joint_positions
        return joint_positions(self.skeleton, self.root, self.rotations, end_sites)

    def crop(self, start: int, stop: int | None = None) -> Motion:
        """Frames ``[start, stop)``."""
        sl = slice(start, stop)
        return replace(self, root=self.root[sl],
                       rotations=None if self.rotations is None else self.rotations[sl],
                       joint_positions=None if self.joint_positions is None else self.joint_positions[sl])

    def resample(self, fps: float) -> Motion:
        """The motion at another frame rate: low-pass filtered before decimating, slerped when upsampling."""
        from dance_core.motion.resample import resample_motion

        return resample_motion(self, fps)

    def mirrored(self) -> Motion:
        """Left/right mirror image across the body's sagittal (YZ) plane, on the same skeleton."""
        pairs = self.skeleton.mirror_pairs()
        root = self.root * np.array([-1.0, 1.0, 1.0])
        if self.rotations is None:
            pos = self.joint_positions[:, pairs] * np.array([-1.0, 1.0, 1.0][: self.joint_positions.shape[-1]])
            return replace(self, root=root, joint_positions=pos)
        rot = self.rotations[:, pairs] * np.array([1.0, -1.0, -1.0, 1.0])
        return replace(self, root=root, rotations=rot)

    def conformed(self, reference: Skeleton, where: str = "motion") -> Motion:
        """This motion with its joints in ``reference``'s order (BVH files list joints depth-first, so
        a skeleton such as SMPL's comes back reordered); an error when the trees differ."""
        if self.skeleton.same_topology(reference):
            return self
        perm = self.skeleton.permutation_to(reference)
        if perm is None:
            raise DataError(f"{where}: skeleton {self.skeleton.name!r} ({len(self.skeleton)} joints) differs "
                            f"from {reference.name!r} ({len(reference)} joints)")
        s = self.skeleton
        inverse = {old: new for new, old in enumerate(perm)}
        skel = Skeleton([s.names[i] for i in perm], [inverse[s.parents[i]] if s.parents[i] >= 0 else -1 for i in perm],
                        s.offsets[perm], [s.channels[i] for i in perm],
                        {inverse[k]: v for k, v in s.end_sites.items()}, s.units, s.up, s.name,
                        {inverse[k]: v for k, v in s.lines.items()}, s.source)
        return replace(self, skeleton=skel,
                       rotations=None if self.rotations is None else self.rotations[:, perm],
                       joint_positions=None if self.joint_positions is None else self.joint_positions[:, perm])

