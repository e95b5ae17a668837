"""Spans of a dance replaced by a regenerated take, everything outside them left bit for bit as it was.

The new take (decoded from the model's own root integration, so somewhere else on the floor) is first
put where the dance is: turned and moved so that its root at the frame before the span stands and faces
as the dance's does there (a span from frame 0: its first frame). Inside the span the take is bent over
its last ``blend`` seconds, joint by joint and along the root's path, toward the dance's frame after the
span, with a raised-cosine weight (:func:`dance_core.motion.loop.ramp`), so it leads into what is kept.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dance_core.motion.loop import ramp
from dance_core.motion.motion import Motion
from dance_core.motion.root import heading
from dance_core.motion.rotations import quat_conj, quat_mul, quat_rotate, quat_slerp, yaw_quat

#: seconds at a span's end over which the new take leads into the kept frames
BLEND = 0.5


def placed(take: Motion, dance: Motion, frame: int) -> Motion:
    """``take`` turned about the vertical and moved on the ground so that at ``frame`` its root stands and
    faces as ``dance``'s does."""
    turn = heading(dance.rotations[frame, 0]) - heading(take.rotations[frame, 0])
    q = yaw_quat(np.full(take.n_frames, turn))
    root = quat_rotate(q, take.root - take.root[frame] * np.array([1.0, 0.0, 1.0]))
    root += dance.root[frame] * np.array([1.0, 0.0, 1.0])
    rotations = take.rotations.copy()
    rotations[:, 0] = quat_mul(q, rotations[:, 0])
    return replace(take, root=root, rotations=rotations)


def splice(dance: Motion, take: Motion, spans: list[tuple[int, int]], blend: float = BLEND) -> Motion:
    """``dance`` with frames ``[a, b)`` of each span from ``take`` (same skeleton, rate and at least as
    many frames up to the last span's end), placed and blended as the module says."""
    rot, root = dance.rotations.copy(), dance.root.copy()
    for a, b in spans:
        b = min(b, dance.n_frames)
        if b <= a:
            continue
        new = placed(take, dance, max(a - 1, 0))
        r, p = new.rotations[a:b].copy(), new.root[a:b].copy()
        if b < dance.n_frames:  # lead into the kept frame after the span
            n = min(max(int(round(blend * dance.fps)), 1), b - a)
            # the pose one step before the kept frame b, extrapolated back from b and b + 1
            before = quat_slerp(dance.rotations[b], dance.rotations[min(b + 1, dance.n_frames - 1)], -1.0)
            before_root = 2 * dance.root[b] - dance.root[min(b + 1, dance.n_frames - 1)]
            w = ramp(n)
            offset = quat_mul(before, quat_conj(r[-1]))
            identity = np.zeros((n, *offset.shape))
            identity[..., 3] = 1.0
            partial = quat_slerp(identity, np.broadcast_to(offset, identity.shape), w[:, None, None])
            r[-n:] = quat_mul(partial, r[-n:])
            p[-n:] += w[:, None] * (before_root - p[-1])
        rot[a:b], root[a:b] = r, p
    return replace(dance, root=root, rotations=rot)
