"""Body parts for joint-wise edits: ``--keep legs=walk.bvh`` takes a part's joints from a given motion and the
rest from the generated dance. Parts are named on the canonical (SMPL-24) joints, found on any skeleton
through its rig map (:func:`dance_core.motion.rig_maps.rig_map`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.rig_maps import rig_map

_LEGS = tuple(f"{s}_{j}" for s in "LR" for j in ("Hip", "Knee", "Ankle", "Foot"))
_ARMS = tuple(f"{s}_{j}" for s in "LR" for j in ("Collar", "Shoulder", "Elbow", "Wrist", "Hand"))
#: each part's canonical joints (their local rotations are taken)
PARTS = {
    "legs": _LEGS,
    "arms": _ARMS,
    "upper": ("Spine1", "Spine2", "Spine3", "Neck", "Head", *_ARMS),
    "lower": ("Pelvis", *_LEGS),
    "root": ("Pelvis",),
}
#: parts that also take the root's path (its position over time)
WITH_PATH = ("legs", "lower", "root")


def check_part(part: str, where: str) -> str:
    """``part`` if it names a body part, else one line naming ``where`` and the parts."""
    if part not in PARTS:
        raise DataError(f"{where}: unknown body part {part!r}; one of {', '.join(PARTS)}")
    return part


def part_joints(motion: Motion, part: str, where: str = "motion") -> list[int]:
    """The indices of ``part``'s joints on ``motion``'s skeleton (those its rig map finds)."""
    joints = rig_map(motion.skeleton, None, where).joints
    return sorted({joints[name] for name in PARTS[check_part(part, where)] if name in joints})


def fitted(source: Motion, n_frames: int) -> Motion:
    """``source`` played over ``n_frames`` frames: cut, or repeated (each repeat carried on from where the
    previous one ended on the ground) when shorter."""
    if source.n_frames >= n_frames:
        return source.crop(0, n_frames)
    reps = -(-n_frames // source.n_frames)
    travel = (source.root[-1] - source.root[0]) * np.array([1.0, 0.0, 1.0])
    root = np.concatenate([source.root + k * travel for k in range(reps)])[:n_frames]
    rot = np.concatenate([source.rotations] * reps)[:n_frames]
    return replace(source, root=root, rotations=rot)


def keep_part(dance: Motion, source: Motion, part: str, where: str = "motion") -> Motion:
    """The dance with ``part``'s joint rotations (and, for legs, lower and root, the root's path placed at
    the dance's start) taken from ``source``, on the same skeleton and at the same frame rate."""
    if source.skeleton.names != dance.skeleton.names:
        raise DataError(f"{where}: its skeleton ({source.skeleton.name}) is not the dance's ({dance.skeleton.name})")
    if abs(source.fps - dance.fps) > 1e-6:
        raise DataError(f"{where}: at {source.fps:g} fps, the dance at {dance.fps:g}")
    src = fitted(source, dance.n_frames)
    rot, root = dance.rotations.copy(), dance.root.copy()
    joints = part_joints(dance, part, where)
    rot[:, joints] = src.rotations[:, joints]
    if part in WITH_PATH:
        root = src.root - src.root[0] * np.array([1.0, 0.0, 1.0]) + dance.root[0] * np.array([1.0, 0.0, 1.0])
    return replace(dance, root=root, rotations=rot)
