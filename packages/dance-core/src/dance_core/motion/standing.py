"""A person standing at ease on any rig: upright, legs as in the rest pose, arms hanging by the sides.

A skeleton's rest pose is a T-pose, an A-pose or anything between; standing at ease is not among them. This
pose takes the rest pose and turns each upper arm to hang down (:data:`ARM_OUT` degrees out to its side and
:data:`ARM_FORWARD` forward) and each forearm :data:`ELBOW_BEND` degrees forward of it, with the joints found
through the rig map (:func:`dance_core.motion.rig_maps.rig_map`). The figure faces +Z with +Y up (the frame
the live poses are in) and its root is raised so its lower sole stands on ``y = 0`` (the grounding's sole,
:func:`dance_core.motion.grounding.soles`).
"""

from __future__ import annotations

import numpy as np

from dance_core.errors import DataError
from dance_core.motion.grounding import GroundingOptions, find_feet, metres_per_unit, soles
from dance_core.motion.ik import rotation_between
from dance_core.motion.motion import Motion
from dance_core.motion.rig_maps import rig_map
from dance_core.motion.rotations import quat_conj, quat_mul, quat_rotate
from dance_core.motion.skeleton import Skeleton

#: degrees an upper arm hangs out from straight down, to its own side; and forward
ARM_OUT, ARM_FORWARD = 8.0, 4.0
#: degrees a forearm bends forward of its upper arm
ELBOW_BEND = 14.0


def _tilted(down: np.ndarray, toward: np.ndarray, degrees: float) -> np.ndarray:
    """``down`` turned ``degrees`` toward the perpendicular direction ``toward``."""
    r = np.radians(degrees)
    return np.cos(r) * down + np.sin(r) * toward


def standing_pose(skeleton: Skeleton, where: str = "") -> tuple[np.ndarray, np.ndarray]:
    """``(root position (3,), local rotations (J, 4) xyzw)`` of the skeleton standing at ease, in its units,
    facing +Z at the origin; one line naming ``where`` for a rig without arms or legs the rig map finds, or
    whose up is not +Y."""
    if skeleton.up != "y":
        raise DataError(f"{where or skeleton.name}: standing needs a +Y-up skeleton (this one is {skeleton.up}-up)")
    joints = rig_map(skeleton, None, where).joints
    rest = skeleton.rest_positions()
    rotations = np.tile([0.0, 0.0, 0.0, 1.0], (len(skeleton), 1))
    world = rotations.copy()  # each joint's world rotation (identity at rest)
    down, forward = np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    for side in "LR":
        shoulder, elbow, wrist = (joints[f"{side}_{j}"] for j in ("Shoulder", "Elbow", "Wrist"))
        if skeleton.parents[elbow] != shoulder or skeleton.parents[wrist] != elbow:
            raise DataError(f"{where or skeleton.name}: the {side} arm's shoulder, elbow and wrist are not a chain")
        outward = np.array([np.sign(rest[shoulder, 0] - rest[joints["Pelvis"], 0]) or 1.0, 0.0, 0.0])
        upper = _tilted(_tilted(down, outward, ARM_OUT), forward, ARM_FORWARD)
        lower = _tilted(upper, forward - (forward @ upper) * upper, ELBOW_BEND)
        parent = world[skeleton.parents[shoulder]]
        turn = rotation_between(rest[elbow] - rest[shoulder], upper)  # world, from the rest (identity) frames
        rotations[shoulder] = quat_mul(quat_conj(parent), turn)
        now = quat_rotate(turn, rest[wrist] - rest[elbow])
        world_elbow = quat_mul(rotation_between(now, lower), turn)
        rotations[elbow] = quat_mul(quat_conj(turn), world_elbow)
        world[shoulder], world[elbow] = turn, world_elbow
    root = np.array(rest[0], np.float64)
    probe = Motion(skeleton, 30.0, root[None], rotations[None])
    heights, feet = soles(probe), find_feet(skeleton)
    if heights is None or feet is None:
        raise DataError(f"{where or skeleton.name}: no feet found to stand on")
    root[1] -= float(heights.min()) / metres_per_unit(skeleton, feet, GroundingOptions())
    return root, rotations
