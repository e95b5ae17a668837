"""Grounding one frame at a time, for ``dance live``: the steps of :func:`~dance_core.motion.grounding.ground`
made causal (see :class:`CausalGrounding`)."""

from __future__ import annotations

from collections import deque
from dataclasses import replace

import numpy as np

from dance_core.motion.grounding import (
    GroundingOptions,
    contact_thresholds,
    find_feet,
    foot_speeds,
    metres_per_unit,
    pin_legs,
    sole_heights,
)
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton


class CausalGrounding:
    """Grounding one frame at a time, from that frame and the ones before it only (``dance live``).

    The steps of :func:`ground` made causal: contacts by the same thresholds (:func:`contact_thresholds`;
    the floor is the lowest sole over the last ``floor_window``, the speeds backward differences; no
    flicker removal, which needs the frames after); the height correction follows the lowest contact
    sole onto ``y = 0`` (kept through a jump, the lowest sole of the last ``max_airborne`` / 2 after that;
    raised so that no foot is below the floor) through two one-pole filters in a row, each with time
    constant ``smoothing`` / 2, so its speed changes smoothly too (a foot that dips is raised within a
    few frames, not at once: clamping it jerked the whole body); a foot is pinned where its contact began
    (the span's mean is not known yet), released over ``blend``.
    Call it with each frame's root ``(3,)`` and local rotations ``(J, 4)``; it returns the grounded root,
    rotations and world joint positions. A skeleton without recognisable feet passes through."""

    def __init__(self, skeleton: Skeleton, fps: float, options: GroundingOptions | None = None):
        self.skeleton, self.fps = skeleton, float(fps)
        self.options = options = options or GroundingOptions()
        self.feet = find_feet(skeleton)
        self.unit = metres_per_unit(skeleton, self.feet, options) if self.feet else 1.0
        self.alpha = 1.0 - np.exp(-2.0 / max(options.smoothing * self.fps, 1e-9))
        self.blend = int(round(options.blend * self.fps))
        self.recent: deque[float] = deque(maxlen=3)  # lowest soles of the last frames (a one-frame dip is no floor)
        self.floor: deque[float] = deque(maxlen=max(1, int(round(options.floor_window * self.fps))))
        self.airborne = max(1, int(round(options.max_airborne * self.fps / 2)))
        self.lows: deque[float] = deque(maxlen=self.airborne)
        self.previous: np.ndarray | None = None  # the last frame's joint positions (before grounding)
        self.on = np.zeros(2, bool)
        self.pins = np.zeros((2, 2))
        self.released = np.full(2, self.blend + 1)  # frames since each foot's contact ended
        self.since = self.airborne + 1  # frames since a contact
        self.target = self.correction = self.filtered = None

    def __call__(self, root: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The frame grounded: ``(root, rotations, positions)``."""
        motion = Motion(self.skeleton, self.fps, np.asarray(root, np.float64)[None], rotations[None])
        if self.feet is None:
            return motion.root[0], motion.rotations[0], motion.positions()[0]
        o, unit = self.options, self.unit
        points = motion.positions(end_sites=True)
        pos = points[:, : len(self.skeleton)]
        heights = sole_heights(motion, points, self.feet, o.sole / unit)[0]
        moved = np.concatenate([self.previous, pos]) if self.previous is not None else np.concatenate([pos, pos])
        speeds = foot_speeds(moved, self.feet, self.fps, vertical=True)[-1]
        self.previous = pos
        self.recent.append(float(heights.min()))
        self.floor.append(float(np.median(self.recent)))
        start, hold = contact_thresholds(heights - min(self.floor), speeds, o, unit)
        began = start & ~self.on
        self.released = np.where(self.on & ~hold, 0, self.released + 1)
        self.on = np.where(self.on, hold, start)
        self.lows.append(float(heights.min()))
        if self.on.any():
            self.target, self.since = -float(heights[self.on].min()), 0
        else:
            self.since += 1
            if self.target is None or self.since > self.airborne:
                self.target = -min(self.lows)
        goal = max(self.target, -float(heights.min()))  # no foot below the floor: a goal, not a clamp (jerk)
        if self.correction is None:
            self.filtered = self.correction = goal
        else:  # two one-pole filters in a row: the correction's speed changes smoothly too
            self.filtered += self.alpha * (goal - self.filtered)
            self.correction += self.alpha * (self.filtered - self.correction)
        lifted = motion.root.copy()
        lifted[0, 1] += self.correction
        ankles = pos[0, list(self.feet[::2])][:, [0, 2]]
        self.pins[began] = ankles[began]
        fade = 1.0 - np.minimum(self.released, self.blend + 1) / (self.blend + 1)
        weight = np.where(self.on, 1.0, fade * fade * (3 - 2 * fade))
        grounded = replace(motion, root=lifted)
        if weight.any():
            grounded = pin_legs(grounded, self.feet, weight[None], self.pins[None])
        return grounded.root[0], grounded.rotations[0], grounded.positions()[0]
