"""A person standing at ease is never still: they breathe, sway over their ankles and look about.

:class:`Idle` adds that to a pose, scaled by a weight (the live figure's rest weight), as a function of time
alone, so the same moment always gives the same pose. Four slow movements, each small:

- **breathing**: the chest pitches :data:`BREATH_DEG` degrees each way every :data:`BREATH_PERIOD` seconds (a
  resting adult takes 12-20 breaths a minute); the neck takes the turn back, so the gaze stays level while the
  shoulders and arms ride on the chest;
- **sway**: the whole body tips about the middle of its ankles, forward and back and side to side, as an
  inverted pendulum does in quiet standing (the ankle strategy), by a few tenths of a degree at periods of 2-14
  seconds (:data:`SWAY_FORWARD`, :data:`SWAY_SIDE`); the feet keep their turn on the floor, and their place
  but for the side sway's tilt of the line between the ankles (1-2 mm up and down at a stance's width);
- **looking about**: the head turns a few degrees left and right (:data:`LOOK`);
- **hanging arms**: each upper arm drifts a degree or two forward and back, the two out of step (:data:`ARMS`).

The amplitudes put the figure's displacement (3-4 mm RMS at the root, 4 at the chest, 6 at the head) at that
of the stillest CMU dancer's stillest two seconds (2.7, 2.9 and 5.5 mm; a quarter of the 29 takes stay under
14, 17 and 19 mm; ``scripts/at_ease.py``). Periods are incommensurate, so the movement does not visibly
repeat. Joints are found through the rig map; a rig without a chest, or without a neck between the chest and
the head, does without breathing.
"""

from __future__ import annotations

import numpy as np

from dance_core.motion.fk import forward_kinematics
from dance_core.motion.ik import axis_angle_quat
from dance_core.motion.rig_maps import rig_map
from dance_core.motion.root import heading
from dance_core.motion.rotations import quat_conj, quat_mul, quat_rotate, yaw_quat
from dance_core.motion.skeleton import Skeleton

#: seconds per breath (15 a minute) and the chest's pitch each way, degrees
BREATH_PERIOD, BREATH_DEG = 4.0, 0.8
#: the body's tip about the ankles, (period s, amplitude degrees, phase rad) terms: forward-back and side to side
SWAY_FORWARD = ((11.3, 0.22, 0.0), (4.7, 0.12, 1.3), (2.3, 0.05, 4.1), (1.3, 0.03, 5.0))
SWAY_SIDE = ((13.7, 0.15, 2.2), (6.1, 0.08, 0.4))
#: the head's turn about the vertical, (period s, amplitude degrees, phase rad) terms
LOOK = ((9.1, 2.5, 0.7), (23.0, 1.5, 3.0))
#: each upper arm's swing forward (+) and back about the body's side axis: left, right
ARMS = (((5.3, 1.2, 0.5), (2.9, 0.5, 2.0)), ((6.7, 1.2, 3.6), (3.1, 0.5, 0.9)))


def _wave(terms: tuple[tuple[float, float, float], ...], t: float) -> float:
    """The sum of the sine terms at ``t`` seconds, in radians."""
    return float(sum(np.radians(a) * np.sin(2 * np.pi * t / p + phase) for p, a, phase in terms))


def _first(joints: dict[str, int], names: tuple[str, ...]) -> int | None:
    """The first of the canonical ``names`` the rig has."""
    return next((joints[n] for n in names if n in joints), None)


class Idle:
    """``__call__(t, root, rotations, w)``: the pose (skeleton units, local xyzw rotations) with the breathing,
    sway and looking about of :mod:`this module <dance_core.motion.idle>` at ``t`` seconds, scaled by ``w``."""

    def __init__(self, skeleton: Skeleton, where: str = ""):
        joints = rig_map(skeleton, None, where).joints
        self.skeleton = skeleton
        self.parents = skeleton.parents
        self.chest = _first(joints, ("Spine3", "Spine2", "Spine1"))
        self.head = joints["Head"]
        above = [self.head]  # the chain from the head down to the chest: the neck takes the breath back
        while above[-1] > 0 and self.parents[above[-1]] != self.chest:
            above.append(self.parents[above[-1]])
        reaches = self.chest is not None and self.parents[above[-1]] == self.chest
        self.neck = above[-1] if reaches and above[-1] != self.head else None
        if self.neck is None:
            self.chest = None  # breathing would tip the head with it
        self.ankles = (joints["L_Ankle"], joints["R_Ankle"])
        self.arms = (joints["L_Shoulder"], joints["R_Shoulder"])

    def __call__(self, t: float, root: np.ndarray, rotations: np.ndarray, w: float
                 ) -> tuple[np.ndarray, np.ndarray]:
        """The pose at ease at time ``t``; unchanged at ``w = 0``."""
        if w <= 0:
            return root, rotations
        positions, world = forward_kinematics(self.skeleton, root, rotations)
        out = rotations.copy()
        facing = yaw_quat(np.array(heading(rotations[0])))
        side, forward = quat_rotate(facing, np.array([1.0, 0.0, 0.0])), quat_rotate(facing, np.array([0.0, 0.0, 1.0]))
        if self.chest is not None:  # the neck's world turn kept: the head rides level on the breathing chest
            breath = axis_angle_quat(side, w * np.radians(BREATH_DEG) * np.sin(2 * np.pi * t / BREATH_PERIOD))
            chest = quat_mul(breath, world[self.chest])
            out[self.chest] = quat_mul(quat_conj(world[self.parents[self.chest]]), chest)
            out[self.neck] = quat_mul(quat_conj(quat_mul(breath, world[self.parents[self.neck]])), world[self.neck])
        # each turn below is in the world as it was: a turned joint's parent is one the breath keeps (the head's)
        # or carries along with it (the arms')
        self._turn(out, world, self.head, yaw_quat(np.array(w * _wave(LOOK, t))))
        for arm, terms in zip(self.arms, ARMS, strict=True):
            self._turn(out, world, arm, axis_angle_quat(side, -w * _wave(terms, t)))
        # the sway: the body tipped about the ankles' middle, each foot turned back to its place on the floor
        tip = quat_mul(axis_angle_quat(side, w * _wave(SWAY_FORWARD, t)),
                       axis_angle_quat(forward, w * _wave(SWAY_SIDE, t)))
        pivot = positions[list(self.ankles)].mean(0)
        out_root = pivot + quat_rotate(tip, root - pivot)
        out[0] = quat_mul(tip, out[0])
        for ankle in self.ankles:
            out[ankle] = quat_mul(quat_conj(quat_mul(tip, world[self.parents[ankle]])), world[ankle])
        return out_root, out

    def _turn(self, local: np.ndarray, world: np.ndarray, joint: int, turn: np.ndarray) -> None:
        """Set ``joint``'s local rotation so that, under its parent as it was, it is turned by ``turn`` (world)."""
        local[joint] = quat_mul(quat_conj(world[self.parents[joint]]), quat_mul(turn, world[joint]))
