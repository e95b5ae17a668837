"""Generated frames decoded one at a time into poses: root position, joint rotations and positions in metres.

Offline, a dance is decoded whole (root deltas integrated from the origin, facing +Z). Live, each frame
is decoded in a window with the frame before it, and the window is placed where that frame stood in the
world: turned by the heading integrated so far (the ``root.dyaw`` channel) and moved to its ground
position, so the figure walks and turns as the offline decoding of the same frames does.

:class:`PoseGrounding` puts each pose on the floor with its contact feet pinned, from that pose and the
ones before it (:class:`dance_core.motion.grounding.CausalGrounding`; ``compose.ground`` looks ahead
and behind, which a live dance cannot).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dance_core.checkpoint import Checkpoint
from dance_core.errors import DataError
from dance_core.motion.grounding import CausalGrounding
from dance_core.motion.rotations import quat_mul, quat_rotate, yaw_quat
from dance_core.motion.skeleton import Skeleton


@dataclass
class Pose:
    """One frame: root position ``(3,)``, local joint rotations ``(J, 4)`` xyzw (None for position-only
    motion), world joint positions ``(J, 3)``, all in metres."""

    root: np.ndarray
    rotations: np.ndarray | None
    positions: np.ndarray


class PoseDecoder:
    """Normalized model frames ``(D,)`` to :class:`Pose` objects, in order."""

    def __init__(self, checkpoint: Checkpoint, registry, fps: float):
        info = checkpoint.motion
        if info.representation is None or info.skeleton is None:
            raise DataError(f"{checkpoint.path}: the model's motion has no skeleton; live poses need one")
        self.skeleton: Skeleton = info.skeleton
        self.rep = info.build_representation(registry)
        self.stats, self.fps = checkpoint.stats.motion, fps
        channels = list(self.rep.channels(self.skeleton))
        self.deltas = "root.dx" in channels
        self.turns = channels.index("root.dyaw") if "root.dyaw" in channels else None
        self.scale = 0.01 if self.skeleton.units == "cm" else 1.0
        self.previous: np.ndarray | None = None
        self.yaw, self.ground = 0.0, np.zeros(3)

    def __call__(self, frame: np.ndarray) -> Pose:
        """The next frame's pose."""
        values = self.stats.invert(np.asarray(frame, np.float64)[None])[0]
        window = values[None] if self.previous is None else np.stack([self.previous, values])
        motion = self.rep.decode(window, self.skeleton, self.fps)
        positions = motion.positions()[-1].copy()
        root = motion.root[-1].copy()
        rotations = None if motion.rotations is None else motion.rotations[-1].copy()
        if self.deltas and self.previous is not None:
            # the window's frame 0 stands at the origin facing +Z: place it where that frame stood
            turn = yaw_quat(np.array(self.yaw))
            shift = self.ground - quat_rotate(turn, motion.root[0] * np.array([1.0, 0.0, 1.0]))
            positions = quat_rotate(turn[None], positions) + shift
            root = quat_rotate(turn, root) + shift
            if rotations is not None:
                rotations[0] = quat_mul(turn, rotations[0])
            if self.turns is not None:
                self.yaw += float(values[self.turns])
        if self.deltas:
            self.ground = root * np.array([1.0, 0.0, 1.0])
        self.previous = values
        s = self.scale
        return Pose(root * s, rotations, positions * s)

    def skeleton_json(self) -> dict:
        """The skeleton as the first JSON line: joint names, parents and rest offsets in metres."""
        return {"skeleton": {"name": self.skeleton.name, "joints": list(self.skeleton.names),
                             "parents": [int(p) for p in self.skeleton.parents],
                             "offsets": (self.skeleton.offsets * self.scale).round(6).tolist(), "fps": self.fps}}


class PoseGrounding:
    """Poses (metres) grounded one by one, causally: the lowest contact sole onto the floor, contact feet
    pinned (:class:`~dance_core.motion.grounding.CausalGrounding`). Position-only poses pass through."""

    def __init__(self, decoder: PoseDecoder):
        self.scale = decoder.scale
        self.grounding = CausalGrounding(decoder.skeleton, decoder.fps)

    def __call__(self, pose: Pose) -> Pose:
        """The pose on the floor."""
        if pose.rotations is None:
            return pose
        root, rotations, positions = self.grounding(pose.root / self.scale, pose.rotations)
        return Pose(root * self.scale, rotations, positions * self.scale)
