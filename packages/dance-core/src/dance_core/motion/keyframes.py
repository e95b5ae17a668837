"""Keyframes: a dance made to pass through given poses at given times, moving into and out of each smoothly.

Each keyframe adds to the dance, joint by joint, the rotation that turns its pose at the keyframe's frame
into the given pose, weighted by a raised-cosine bump that is 1 at the keyframe and 0 at ``half`` seconds
either side (less when keyframes are closer: their bumps never overlap). The dance keeps its own movement
through the keyframe; what is added is smooth, so the jerk it brings is bounded by the pose difference.
The root keeps the dance's heading (the pose's tilt and height are taken), so a keyframe does not spin the
dancer round; the ground path is the dance's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.root import heading
from dance_core.motion.rotations import quat_conj, quat_mul, quat_slerp, yaw_quat

#: seconds either side of a keyframe over which the dance moves into and out of its pose
HALF = 1.0
#: keyframes closer than this (seconds) are refused: the dance could not move between them
MIN_GAP = 0.25


@dataclass(frozen=True)
class Keyframe:
    """A pose (``rotations (J, 4)`` local quaternions, ``height`` of the root) to pass through at ``time`` s;
    ``where`` names it in errors."""

    time: float
    rotations: np.ndarray
    height: float
    where: str = "keyframe"


def keyframe_of(motion: Motion, time: float, frame: int = 0, where: str = "keyframe") -> Keyframe:
    """Frame ``frame`` of ``motion`` as a keyframe at ``time``; a frame the motion lacks is one line."""
    if not 0 <= frame < motion.n_frames:
        raise DataError(f"{where}: frame {frame} is past the motion's {motion.n_frames} frames")
    if motion.rotations is None:
        raise DataError(f"{where}: a keyframe pose needs joint rotations")
    return Keyframe(float(time), motion.rotations[frame].copy(), float(motion.root[frame, 1]), where)


def bump(n: int, center: int, half: float) -> np.ndarray:
    """``(n,)`` weights: 1 at ``center``, a raised cosine down to 0 at ``half`` frames either side."""
    d = np.abs(np.arange(n) - center) / max(half, 1e-9)
    return np.where(d < 1.0, 0.5 + 0.5 * np.cos(np.pi * np.minimum(d, 1.0)), 0.0)


def check_keyframes(keyframes: list[Keyframe], duration: float) -> list[Keyframe]:
    """The keyframes by time; one past the dance or two too close is one line naming it."""
    ordered = sorted(keyframes, key=lambda k: k.time)
    for k in ordered:
        if not 0.0 <= k.time < duration:
            raise DataError(f"{k.where}: at {k.time:g} s, past the dance's {duration:.2f} s")
    for a, b in zip(ordered, ordered[1:], strict=False):
        if b.time - a.time < MIN_GAP:
            raise DataError(f"{b.where}: {b.time - a.time:.2f} s after {a.where}; keyframes need {MIN_GAP:g} s "
                            "between them")
    return ordered


def hit(motion: Motion, keyframes: list[Keyframe], half: float = HALF) -> Motion:
    """The dance passing through every keyframe's pose at its time (see the module)."""
    ordered = check_keyframes(keyframes, motion.duration)
    rot, root = motion.rotations.copy(), motion.root.copy()
    n, fps = motion.n_frames, motion.fps
    frames = [min(int(round(k.time * fps)), n - 1) for k in ordered]
    for i, (k, f) in enumerate(zip(ordered, frames, strict=True)):
        if k.rotations.shape != rot.shape[1:]:
            raise DataError(f"{k.where}: the pose has {len(k.rotations)} joints, the dance {rot.shape[1]}")
        gaps = [f - frames[i - 1]] if i else []
        gaps += [frames[i + 1] - f] if i + 1 < len(frames) else []
        w = bump(n, f, min([half * fps, *(g / 2.0 for g in gaps)]))
        target = k.rotations.copy()
        key_yaw, own_yaw = heading(target[0]), heading(rot[f, 0])
        target[0] = quat_mul(yaw_quat(own_yaw), quat_mul(quat_conj(yaw_quat(key_yaw)), target[0]))
        offset = quat_mul(target, quat_conj(rot[f]))  # per joint, from the dance's pose to the keyframe's
        near = w > 0
        identity = np.zeros((int(near.sum()), *offset.shape))
        identity[..., 3] = 1.0
        partial = quat_slerp(identity, np.broadcast_to(offset, identity.shape), w[near][:, None, None])
        rot[near] = quat_mul(partial, rot[near])
        root[near, 1] += w[near] * (k.height - root[f, 1])
    return replace(motion, root=root, rotations=rot)


def pose_error(motion: Motion, keyframe: Keyframe) -> float:
    """The largest distance (the motion's units) between a joint of the dance at the keyframe's frame and
    the same joint of the keyframe's pose, both seen from their root facing +Z."""
    f = min(int(round(keyframe.time * motion.fps)), motion.n_frames - 1)
    at = motion.crop(f, f + 1)
    pose = replace(at, rotations=keyframe.rotations[None], root=np.array([[0.0, keyframe.height, 0.0]]))

    def seen(m: Motion) -> np.ndarray:
        p = m.positions()[0] - m.root[0] * np.array([1.0, 0.0, 1.0])
        from dance_core.motion.rotations import quat_rotate

        return quat_rotate(quat_conj(yaw_quat(heading(m.rotations[0, 0]))), p)

    return float(np.linalg.norm(seen(at) - seen(pose), axis=-1).max())
