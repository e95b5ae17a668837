"""Loops: a dance whose last frame leads into its first, for a clip played over and over.

The last ``seconds`` are bent, joint by joint, toward the pose that would come just before the first frame
(the first frame stepped back by its own first step: rotations extrapolated by slerp, the root by its
velocity), with a raised-cosine weight that is 0 where the bend starts and 1 on the last frame. What is
added is a smooth offset, so the tail keeps its own movement; the root's position and heading come back
to the start, so the wrap-around step is one ordinary frame step.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dance_core.motion.motion import Motion
from dance_core.motion.rotations import quat_conj, quat_mul, quat_slerp

#: seconds over which the end is bent into the start (about two beats at 120 bpm)
SECONDS = 1.0


def ramp(n: int) -> np.ndarray:
    """A raised-cosine weight over ``n`` frames, from 0 (exclusive) up to 1 at the last frame."""
    x = np.arange(1, n + 1) / n
    return 0.5 - 0.5 * np.cos(np.pi * x)


def looped(motion: Motion, seconds: float = SECONDS) -> Motion:
    """The dance with its last ``seconds`` (at most half of it) bent so that its last frame leads into
    its first."""
    n = motion.n_frames
    if motion.rotations is None or n < 4:
        return motion
    span = int(min(max(round(seconds * motion.fps), 2), n // 2))
    rot, root = motion.rotations, motion.root
    before = quat_slerp(rot[0], rot[1], -1.0)  # the pose one step before the first frame
    before_root = 2 * root[0] - root[1]
    w = ramp(span)
    tail = slice(n - span, n)
    offset = quat_mul(before, quat_conj(rot[-1]))  # per joint, from the last frame to the pose before the first
    identity = np.zeros_like(offset)
    identity[..., 3] = 1.0
    partial = quat_slerp(np.broadcast_to(identity, (span, *offset.shape)), np.broadcast_to(offset, (span,
                         *offset.shape)), w[:, None, None])
    rotations = rot.copy()
    rotations[tail] = quat_mul(partial, rot[tail])
    path = root.copy()
    path[tail] = root[tail] + w[:, None] * (before_root - root[-1])
    return replace(motion, root=path, rotations=rotations)


def wrap_jump(motion: Motion) -> float:
    """The largest joint displacement (the motion's units) from its last frame to its first."""
    pos = motion.positions()
    return float(np.linalg.norm(pos[0] - pos[-1], axis=-1).max())
