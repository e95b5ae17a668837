"""Generated frames decoded one at a time into poses: root position, joint rotations and positions in metres.

Offline, a dance is decoded whole (root deltas integrated from the origin, facing +Z). Live, each frame
is decoded in a window with the frame before it, and the window is placed where that frame stood in the
world: turned by the heading integrated so far (the ``root.dyaw`` channel) and moved to its ground
position, so the figure walks and turns as the offline decoding of the same frames does.

:class:`LivePoses` chains what follows the decoding, in offline's order: grounding from each pose and the
ones after it the beat lock's lag lets it see (:class:`dance_core.motion.buffered_grounding.BufferedGrounding`,
``compose.ground``'s steps on a rolling buffer), or without the lock causally
(:class:`dance_core.motion.causal_grounding.CausalGrounding`), then beat locking (:mod:`dance_core.live.beat_lock`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from dance_core.checkpoint import Checkpoint
from dance_core.errors import DataError
from dance_core.live.beat_lock import BeatClock, BeatLock
from dance_core.live.rest import RestBlend
from dance_core.motion.buffered_grounding import LOOKAHEAD, BufferedGrounding
from dance_core.motion.causal_grounding import CausalGrounding
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
        """The next frame's pose (metres)."""
        root, rotations, positions = self.decode(frame)
        return Pose(root * self.scale, rotations, positions * self.scale)

    def decode(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """The next frame's root, local rotations and joint positions, in the skeleton's units."""
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
        return root, rotations, positions

    def skeleton_json(self) -> dict:
        """The skeleton as the first JSON line: joint names, parents and rest offsets in metres."""
        return {"skeleton": {"name": self.skeleton.name, "joints": list(self.skeleton.names),
                             "parents": [int(p) for p in self.skeleton.parents],
                             "offsets": (self.skeleton.offsets * self.scale).round(6).tolist(), "fps": self.fps}}


class LivePoses:
    """Model frames in, the poses sent out (metres): decoded, grounded with ``ground`` (position-only motion is
    not), then beat-locked when ``clock`` is given (:class:`~dance_core.live.beat_lock.BeatLock`; the re-timing
    keeps planted feet planted). The beat lock plays the dance about a second behind generation, so its poses
    are grounded with ``lookahead`` seconds of the frames after them
    (:class:`~dance_core.motion.buffered_grounding.BufferedGrounding`, the whole dance's steps on a rolling
    buffer) at no cost in latency: the lock never plays a frame before its grounding is done; without the lock
    each pose is grounded from itself and the ones before it
    (:class:`~dance_core.motion.causal_grounding.CausalGrounding`). With ``rest``, each pose is last blended
    toward standing at ease by the rest weight it is given (:class:`~dance_core.live.rest.RestBlend`).
    ``note`` and ``rest_note`` say what could not be done."""

    def __init__(self, decoder: PoseDecoder, ground: bool = True, clock: BeatClock | None = None,
                 lookahead: float = LOOKAHEAD, rest: bool = False):
        self.decoder, self.scale, self.note, self.rest_note = decoder, decoder.scale, "", ""
        self.rest = None
        if rest:
            try:
                self.rest = RestBlend(decoder.skeleton)
            except DataError as exc:
                self.rest_note = f"no rest in silence: {exc}"
        self.lock = None
        if clock is not None:
            try:
                self.lock = BeatLock(decoder.skeleton, decoder.fps, clock)
            except DataError as exc:
                self.note = f"not beat-locked: {exc}"
        self.grounding: CausalGrounding | BufferedGrounding | None = None
        if ground:
            skeleton, fps = decoder.skeleton, decoder.fps
            self.grounding = (BufferedGrounding(skeleton, fps, lookahead) if self.lock is not None and lookahead > 0
                              else CausalGrounding(skeleton, fps))
        delay = self.grounding.delay if isinstance(self.grounding, BufferedGrounding) else 0
        self.indices: deque[int] = deque(maxlen=delay + 1)  # the frames in the grounding's buffer not given out

    @property
    def lookahead(self) -> float:
        """Seconds of later frames each pose's grounding sees (0: causal, or not grounded)."""
        if isinstance(self.grounding, BufferedGrounding):
            return self.grounding.delay / self.decoder.fps
        return 0.0

    def __call__(self, index: int, frame: np.ndarray, rest: float = 0.0) -> Pose:
        """The pose for music frame ``index`` from the model's frame of that index, at rest weight ``rest``."""
        root, rotations, positions = self.decoder.decode(frame)
        made = index  # the generated frame the pose (root, rotations, positions) is of
        if isinstance(self.grounding, BufferedGrounding) and rotations is not None:
            self.indices.append(index)  # the frame given back is the one pushed `delay` calls ago (drops skip indices)
            grounded = self.grounding.push(root, rotations)
            if grounded is None:  # the lock holds the first pose meanwhile
                return self._shown(*self.grounding.peek(), rest, index)
            made, (root, rotations, positions) = self.indices[0], grounded
        elif self.grounding is not None and rotations is not None:
            root, rotations, positions = self.grounding(root, rotations)
        if self.lock is not None:  # as offline: the accents of the feet as they will be seen
            self.lock.push(made, root, rotations, positions)
            root, rotations, positions = self.lock.pose(index)
        return self._shown(root, rotations, positions, rest, index)

    def _shown(self, root: np.ndarray, rotations: np.ndarray | None, positions: np.ndarray, rest: float,
               index: int) -> Pose:
        """The pose of music frame ``index`` as sent (metres), blended toward rest."""
        if self.rest is not None and rotations is not None:
            root, rotations, positions = self.rest(root, rotations, positions, rest, index / self.decoder.fps)
        return Pose(root * self.scale, rotations, positions * self.scale)
