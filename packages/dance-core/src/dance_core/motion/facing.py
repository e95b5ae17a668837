"""Facing: a dance kept facing the camera, and its turning speed limited.

The heading is the root's yaw (:func:`dance_core.motion.root.heading`). ``camera`` removes its slow drift
(a high-pass: the heading minus its Gaussian-smoothed self over ``window`` seconds) and bounds what is left
softly (``spread * tanh(x / spread)``), so quick turns stay quick but never leave the camera's side: the
front is +Z, where glTF characters face and the HTML preview's camera looks from (35 degrees off it). The
root's travel turns with the body: each frame's ground step is turned by that frame's change of heading.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.ndimage import gaussian_filter1d

from dance_core.motion.motion import Motion
from dance_core.motion.root import heading
from dance_core.motion.rotations import quat_mul, quat_rotate, yaw_quat

#: how far (radians) a dance facing the camera may turn from it, softly
SPREAD = np.radians(60.0)
#: seconds over which heading drift counts as slow (its Gaussian's sigma is a quarter of it)
WINDOW = 4.0


def limit_turning(yaw: np.ndarray, fps: float, max_turn: float) -> np.ndarray:
    """An unwrapped heading ``(T,)`` whose frame-to-frame change is at most ``max_turn`` degrees a second."""
    step = np.radians(max_turn) / fps
    return yaw[0] + np.concatenate([[0.0], np.cumsum(np.clip(np.diff(yaw), -step, step))])


def camera_heading(yaw: np.ndarray, fps: float, window: float = WINDOW, spread: float = SPREAD) -> np.ndarray:
    """An unwrapped heading's quick part, softly bounded to ``spread`` around facing +Z."""
    slow = gaussian_filter1d(yaw, sigma=max(window * fps / 4.0, 1.0), mode="nearest")
    return spread * np.tanh((yaw - slow) / spread)


def turned(motion: Motion, new_yaw: np.ndarray) -> Motion:
    """The motion with its root heading ``new_yaw`` (radians per frame), its ground path turned with it."""
    yaw = np.unwrap(heading(motion.rotations[:, 0]))
    delta = new_yaw - yaw
    turn = yaw_quat(delta)
    rotations = motion.rotations.copy()
    rotations[:, 0] = quat_mul(turn, rotations[:, 0])
    step = np.diff(motion.root, axis=0)
    step[:, 1] = 0.0
    step = quat_rotate(turn[1:], step)
    root = motion.root.copy()
    root[1:, [0, 2]] = motion.root[0, [0, 2]] + np.cumsum(step, axis=0)[:, [0, 2]]
    return replace(motion, root=root, rotations=rotations)


def face(motion: Motion, mode: str = "camera", max_turn: float | None = None) -> Motion:
    """The dance facing the camera (``mode="camera"``) or as it is (``free``), turning at most ``max_turn``
    degrees a second when given."""
    if motion.rotations is None or motion.n_frames < 2 or (mode == "free" and max_turn is None):
        return motion
    yaw = np.unwrap(heading(motion.rotations[:, 0]))
    new = limit_turning(yaw, motion.fps, max_turn) if max_turn is not None else yaw
    if mode == "camera":
        new = camera_heading(new, motion.fps)
    return turned(motion, new)
