"""Grounding with a look-ahead, for ``dance live`` when its beat lock plays the dance behind generation:
:func:`~dance_core.motion.grounding.ground`'s whole-dance steps run on a rolling buffer (see
:class:`BufferedGrounding`)."""

from __future__ import annotations

from collections import deque

import numpy as np

from dance_core.motion.grounding import (
    GroundingOptions,
    drop_needed,
    find_feet,
    metres_per_unit,
    pin_legs,
    pin_shifts,
    settled_contacts,
    sole_heights,
    span_pins,
    vertical_correction,
)
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton

#: seconds of frames after a frame that its grounding sees (``dance live``: within the beat lock's 1-s lag, whose
#: accents are found on the grounded frames, so seen this much later). Simulated on the four fixture songs and
#: three synthesized ones, the locking as a share of offline's: causal grounding 79 %, 0.1 s 78 %, 0.25 s 72 %,
#: (fixture songs only) 0.5 s 35 %; the grounding alike from 0.05 s on (floating 0.6-1.0 % against 3.0-4.5 %)
LOOKAHEAD = 0.1
#: seconds: the time constants of each of the three one-pole filters in a row that smooth the knee-keeping drop,
#: as it grows and as it shrinks. Chosen on raw dances of the bundled default (30 s of each fixture song, grounded
#: frame by frame) and two test dancers: knees 51.5° live against 46.6° offline (47.5° raw; without the drop
#: 40.6°), the pelvis' vertical jerk 1.12x offline's as without the drop; a sliding plié keeps its knees within
#: 2.1° (without the drop 10° straighter); a bobbing stepper's vertical jerk 1.13x offline's. Faster filters
#: follow the pins better and shake the pelvis (0.03 s both ways: jerk 2.1x), slower ones straighten the knees
DROP_SMOOTHING = (0.1, 0.2)


class BufferedGrounding:
    """Frames in, each frame out ``lookahead`` seconds later, grounded by :func:`ground`'s own steps over a
    rolling buffer: the frames since half a ``floor_window`` before it and the ``lookahead`` after it.

    The steps are the whole dance's (:func:`settled_contacts` with flicker removal, :func:`vertical_correction`
    smoothed both ways, :func:`pin_shifts` with their fades); what a frame already given out decided is kept:
    its contacts, and its contact span's pin, so a planted foot does not move as the buffer slides. A frame's
    height correction is the mean of those found for it on each push while it was in the look-ahead: the
    last one alone changes from frame to frame with what the buffer's end shows (the body's vertical jerk
    2.6x offline grounding's on a generated dance); each keeps every foot above the floor, so their mean does. A span's
    pin is its median ankle position (offline's) when the span ends within the buffer as it begins, else the
    median of the part the buffer holds. Where a pinned leg would be stretched the pelvis comes down, as
    offline (:func:`~dance_core.motion.grounding.knee_drop`): each frame given out takes the largest drop
    needed over its look-ahead, under the most any unpinned foot allows, through three one-pole filters in a
    row (``drop_smoothing``: their time constants in seconds while the drop grows and while it shrinks; None:
    no drop), decided once, so the pelvis does not jump with what the buffer's end shows; the ankles of
    pinned feet are held where they were, and a foot not pinned keeps its height, its knee bending under the
    lowered pelvis. ``push(root (3,), rotations (J, 4))`` returns the grounded frame ``delay`` frames back as
    ``(root, rotations, positions)``, or None while the buffer fills (``peek()`` gives the first frame grounded
    on what has arrived). A skeleton without recognisable feet passes through (after the same delay)."""

    def __init__(self, skeleton: Skeleton, fps: float, lookahead: float = LOOKAHEAD,
                 options: GroundingOptions | None = None,
                 drop_smoothing: tuple[float, float] | None = DROP_SMOOTHING):
        self.skeleton, self.fps = skeleton, float(fps)
        self.options = options = options or GroundingOptions()
        self.feet = find_feet(skeleton)
        self.unit = metres_per_unit(skeleton, self.feet, options) if self.feet else 1.0
        self.delay = max(1, int(round(lookahead * self.fps)))
        self.history = max(1, int(round(options.floor_window * self.fps / 2)))
        self.blend = int(round(options.blend * self.fps))
        size = self.history + self.delay + 1
        self.roots: deque[np.ndarray] = deque(maxlen=size)
        self.rotations: deque[np.ndarray] = deque(maxlen=size)
        self.points: deque[np.ndarray] = deque(maxlen=size)  # each frame's joints and End Sites, found once
        self.contacts: deque[np.ndarray] = deque(maxlen=self.history)  # of the frames given out
        self.pins: deque[np.ndarray] = deque(maxlen=self.history)
        self.given = 0  # frames given out
        self.pushed = 0  # frames taken
        # the height corrections found on the last pushes, each with the frame it starts at
        self.guesses: deque[tuple[int, np.ndarray]] = deque(maxlen=self.delay + 1)
        # the knee-keeping drop's filter states (None: no drop); each step moves them this share of the way
        self.drop = None if drop_smoothing is None else np.zeros(3)
        self.follow, self.release = (1.0 - np.exp(-1.0 / max(tau, 1e-6) / self.fps) for tau in drop_smoothing or (1, 1))

    def push(self, root: np.ndarray, rotations: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Take the next frame; the frame ``delay`` before it grounded, or None while the buffer fills."""
        self.pushed += 1
        self.roots.append(np.asarray(root, np.float64))
        self.rotations.append(np.asarray(rotations, np.float64))
        frame = Motion(self.skeleton, self.fps, self.roots[-1][None], self.rotations[-1][None])
        self.points.append(frame.positions(end_sites=self.feet is not None)[0])
        index = len(self.roots) - 1 - self.delay  # the frame given out, in the buffer
        if index < 0:
            return None
        self.given += 1
        return self._ground(index, keep=True)

    def peek(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The buffer's first frame grounded on the frames there so far (while nothing was given out)."""
        return self._ground(0, keep=False)

    def _ground(self, index: int, keep: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Buffer frame ``index`` grounded; ``keep``: remember its contacts and pins (it is given out)."""
        if self.feet is None:
            return self.roots[index], self.rotations[index], self.points[index]
        o, unit, feet, joints = self.options, self.unit, self.feet, len(self.skeleton)
        points = np.stack(self.points)
        # the buffer as joint positions (found once per frame): what the grounding steps read of it
        motion = Motion(self.skeleton, self.fps, np.stack(self.roots), joint_positions=points[:, :joints])
        heights = sole_heights(motion, points, feet, o.sole / unit)
        contacts, _ = settled_contacts(motion, heights, feet, o, unit)
        fixed = np.full((len(heights), 2, 2), np.nan)
        if index:  # the frames given out keep what they decided
            contacts[:index] = np.stack(self.contacts)[-index:]
            fixed[:index] = np.stack(self.pins)[-index:]
        correction = vertical_correction(heights, contacts, self.fps, o)
        first = self.pushed - len(correction)  # the buffer's first frame
        height = float(correction[index])
        if keep:  # the mean of the corrections found for this frame while it was in the look-ahead
            self.guesses.append((first, correction))
            height = float(np.mean([c[first + index - f] for f, c in self.guesses]))
        pos = points[:, :joints].copy()
        pos[..., 1] += correction[:, None]
        pos[index, :, 1] += height - correction[index]
        pins = span_pins(pos, feet, contacts, fixed)
        shifts = pin_shifts(self.skeleton, pos, feet, contacts, self.blend, heights + correction[:, None], pins)
        if keep:
            self.contacts.append(contacts[index])
            self.pins.append(pins[index])
        weights = ((shifts != 0).any(-1) | contacts).astype(float)
        pinned = pos[:, list(feet[::2])] + shifts
        drop = self._drop(pos, weights, pinned, heights + correction[:, None], index, keep)
        root = self.roots[index].copy()
        root[1] += height - drop
        frame = Motion(self.skeleton, self.fps, root[None], self.rotations[index][None])
        weight, target = weights[index].copy(), pinned[index].copy()  # pinned ankles held where they were
        # a foot not (fully) pinned keeps its height, its leg taking up the drop. The filtered drop lags the look-ahead
        # (its release takes about 0.6 s), and lowering such a foot with the body brought swinging feet down to skim
        # the floor: over eight dances (the four fixture songs x seeds 0-1, 30 s, each bundled model's raw frames
        # grounded live and offline) skating 0.527 m/s against offline's 0.460 (default) and 0.242 against 0.176
        # (tm2d-small); held, 0.471 and 0.192, jerk 92 and 113 m/s^3 against 94 and 122 (offline 92 and 112), knees
        # 47.9 and 54.9 degrees against 46.9 and 54.5 (offline 44.8 and 52.4), the pelvis' vertical jerk unchanged
        if drop > 0:  # each ankle's target from the lowered body, raised by the part of the drop its pin does not hold
            ankles = pos[index, list(feet[::2])] - np.array([0.0, drop, 0.0])
            target = ankles + weight[:, None] * (target - ankles)
            target[:, 1] += (1.0 - weight) * drop
            weight = np.ones_like(weight)
        if not weight.any():
            lowered = pos[index].copy()
            lowered[:, 1] -= drop
            return root, frame.rotations[0], lowered
        frame = pin_legs(frame, feet, weight[None], target[None])
        return frame.root[0], frame.rotations[0], frame.positions()[0]

    def _drop(self, pos: np.ndarray, weights: np.ndarray, pinned: np.ndarray, soles: np.ndarray, index: int,
              keep: bool) -> float:
        """How far buffer frame ``index`` comes down so pinned legs keep their bend (skeleton units); ``keep``:
        the frame is given out, and the filters step."""
        if self.drop is None:
            return 0.0
        if not keep:
            return float(self.drop[-1])
        need, cap = drop_needed(self.skeleton, pos, self.feet, weights, pinned, soles, self.options)
        # the most any frame of the look-ahead needs, under the least any of them allows
        value = min(float(need[index:].max()), float(cap[index:].min()))
        for k in range(len(self.drop)):
            self.drop[k] += (self.follow if value > self.drop[k] else self.release) * (value - self.drop[k])
            value = float(self.drop[k])
        return max(value, 0.0)
