"""The figure at rest: live poses blended toward a person standing at ease by a rest weight from 0 to 1.

At weight ``w`` each joint's rotation is slerped ``w`` of the way to the standing pose
(:func:`dance_core.motion.standing.standing_pose`), the root's height moved ``w`` of the way to its standing
height, and the root's upright rotation kept facing where the figure faces. Travel and turning are slowed
by ``1 - w``: the figure's ground position and heading advance by ``1 - w`` of the dance's own steps, so it
stops where it is and, when the dance resumes, goes on from there (the dance beneath may have moved on;
the difference is carried as a turn and a shift about the vertical, not shown as a jump). The standing figure
is not a statue: it breathes, sways over its ankles and looks about (:class:`dance_core.motion.idle.Idle`, by
the same weight, at the music time ``t`` it is given). At weight 0 after no rest, poses pass unchanged.
"""

from __future__ import annotations

import numpy as np

from dance_core.motion.fk import joint_positions
from dance_core.motion.idle import Idle
from dance_core.motion.root import heading, wrap
from dance_core.motion.rotations import quat_mul, quat_rotate, quat_slerp, yaw_quat
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.standing import standing_pose


class RestBlend:
    """``__call__(root, rotations, positions, w, t)``: a pose (skeleton units, local xyzw rotations) with rest
    weight ``w`` at music time ``t`` seconds, as the figure shows it. ``DataError`` (one line) for a rig with no
    standing pose."""

    def __init__(self, skeleton: Skeleton, where: str = "live"):
        self.skeleton = skeleton
        self.stand_root, self.stand = standing_pose(skeleton, where)
        self.idle = Idle(skeleton, where)
        self.turn = 0.0  # radians the figure's heading is behind the dance's, from rests
        self.place: np.ndarray | None = None  # the figure's ground position (x, z), once it has rested
        self.last: tuple[np.ndarray, float] | None = None  # the dance's previous ground position and heading

    def __call__(self, root: np.ndarray, rotations: np.ndarray, positions: np.ndarray, w: float, t: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pose shown at rest weight ``w`` in ``[0, 1]`` at ``t`` seconds."""
        ground, yaw = root[[0, 2]].astype(np.float64), float(heading(rotations[0]))
        if self.last is not None and (w > 0 or self.place is not None):
            step, turned = ground - self.last[0], float(wrap(yaw - self.last[1]))
            if self.place is None:
                self.place = self.last[0].copy()
            self.turn -= w * turned  # the heading advances by (1 - w) of the dance's turn
            spin = yaw_quat(np.array(self.turn))
            moved = quat_rotate(spin, np.array([step[0], 0.0, step[1]]))
            self.place = self.place + (1.0 - w) * moved[[0, 2]]
        self.last = (ground, yaw)
        if self.place is None:
            return root, rotations, positions
        spin = yaw_quat(np.array(self.turn))
        out_rot = rotations.copy()
        out_rot[0] = quat_mul(spin, rotations[0])
        out_root = np.array([self.place[0], root[1], self.place[1]])
        if w > 0:
            upright = quat_mul(yaw_quat(np.array(heading(out_rot[0]))), self.stand[0])
            target = self.stand.copy()
            target[0] = upright
            out_rot = quat_slerp(out_rot, target, w)
            out_root[1] = (1.0 - w) * root[1] + w * self.stand_root[1]
            out_root, out_rot = self.idle(t, out_root, out_rot, w)
        return out_root, out_rot, joint_positions(self.skeleton, out_root, out_rot)
