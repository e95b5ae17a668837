"""Kinematic move detectors from joint positions alone: jump, clap, spin, kick, arms raised.

Each detector reads SMPL-24 joint positions ``(T, 24, 3)`` (metres, Y up) and returns a boolean per
frame: the frames where that move is seen. They are written from first principles, from what the move
does to the body, and share no code with any generator (nothing here imports ``dance_core.data``), so
they can judge whether a generated dance performs a move it was asked for:

- **jump**: both feet off the floor (the lowest foot joint more than ``JUMP_FEET`` above the local
  floor, the 10th percentile of the lowest foot over ``FLOOR_SECONDS``) while the pelvis is more than
  ``JUMP_PELVIS`` above its own running 10th percentile over the same window;
- **clap**: the hands, in front of the body (their midpoint more than ``CLAP_AHEAD`` ahead of the
  pelvis and ``CLAP_HEIGHT`` above it), come within ``CLAP_CLOSE`` of each other at a local minimum of
  their distance, having been at least ``CLAP_APPROACH`` farther apart within ``CLAP_LEAD`` seconds
  before (a fast approach, not hands merely held together); the frames of the approach are marked.
  ``CLAP_CLOSE`` is 60 cm, not a touch: the synthetic dancer's clap leaves 40-60 cm between its hand
  joints on the default skeleton (``dance24``; its arms swing from the shoulders alone, and its shoulders
  are wider and its arms longer than those of the SMPL template it replaced, on which the clap left 30-50
  cm and the threshold was 50 cm), so this detects the hands swung together in front on the beat rather
  than their contact;
- **spin**: the facing direction (the hips' left-right axis on the ground plane) turns more than
  ``SPIN_DEGREES`` within ``SPIN_SECONDS`` while the pelvis's path on the ground is shorter than
  ``SPIN_TRAVEL`` (a turn on the spot, not a walk round a circle); the frames of such a stretch that
  turn faster than ``SPIN_RATE`` degrees per second are marked;
- **kick**: one ankle more than ``KICK_FORWARD`` in front of the pelvis (along the facing direction)
  and more than ``KICK_LIFT`` above the other ankle;
- **arms-up** (the synthetic dancer's arm-wave): both wrists more than ``ARMS_ABOVE`` above the head
  joint, not held out in front of the body.

:func:`move_share` turns a detection into how often a move occurs in a stretch of time: the share of
its whole seconds in which the detector fires at least once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from dance_core.errors import DataError

#: SMPL-24 joint indices used here (the order of the SMPL body model)
(PELVIS, L_HIP, R_HIP, L_ANKLE, R_ANKLE, L_FOOT, R_FOOT, HEAD, L_WRIST, R_WRIST, L_HAND,
 R_HAND) = 0, 1, 2, 7, 8, 10, 11, 15, 20, 21, 22, 23

FLOOR_SECONDS = 4.0
JUMP_FEET, JUMP_PELVIS = 0.04, 0.05
CLAP_CLOSE, CLAP_APPROACH, CLAP_LEAD, CLAP_AHEAD, CLAP_HEIGHT = 0.6, 0.25, 0.3, 0.1, -0.1
SPIN_DEGREES, SPIN_SECONDS, SPIN_TRAVEL, SPIN_RATE = 270.0, 2.5, 0.5, 90.0
KICK_FORWARD, KICK_LIFT = 0.3, 0.12
ARMS_ABOVE, ARMS_AHEAD = 0.05, 0.2


def _check(positions: np.ndarray) -> np.ndarray:
    positions = np.asarray(positions, dtype=np.float64)
    if positions.ndim != 3 or positions.shape[1] != 24 or positions.shape[2] != 3:
        raise DataError(f"move detectors: positions must be (frames, 24, 3) SMPL-24 joints, got {positions.shape}")
    return positions


def _running(values: np.ndarray, frames: int, q: float) -> np.ndarray:
    """The ``q``-th percentile of ``values`` in a centred window of ``frames`` frames (edges: shrunk)."""
    half = max(1, frames // 2)
    padded = np.pad(values, half, mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1)
    return np.percentile(windows, q, axis=1)[: len(values)]


def facing(positions: np.ndarray) -> np.ndarray:
    """Unwrapped facing angle (radians about +Y) per frame, from the hips' right-to-left axis on the ground
    plane: at rest the body faces +Z with its left at +X (angle 0); facing ``(sin a, cos a)`` on (x, z)."""
    across = positions[:, L_HIP] - positions[:, R_HIP]
    return np.unwrap(np.arctan2(-across[:, 2], across[:, 0]))


def detect_jump(positions: np.ndarray, fps: float) -> np.ndarray:
    """Frames of a jump: both feet off the floor and the pelvis raised."""
    p = _check(positions)
    window = int(round(FLOOR_SECONDS * fps))
    feet = p[:, [L_ANKLE, R_ANKLE, L_FOOT, R_FOOT], 1].min(axis=1)
    pelvis = p[:, PELVIS, 1]
    return (feet - _running(feet, window, 10) > JUMP_FEET) & (pelvis - _running(pelvis, window, 10) > JUMP_PELVIS)


def detect_clap(positions: np.ndarray, fps: float) -> np.ndarray:
    """Frames of a clap: the hands, held in front of the chest, brought together fast to a close minimum."""
    p = _check(positions)
    yaw = facing(p)
    forward = np.stack([np.sin(yaw), np.cos(yaw)], axis=1)
    middle = (p[:, L_HAND] + p[:, R_HAND]) / 2 - p[:, PELVIS]
    front = (np.sum(middle[:, [0, 2]] * forward, axis=1) > CLAP_AHEAD) & (middle[:, 1] > CLAP_HEIGHT)
    gap = np.linalg.norm(p[:, L_HAND] - p[:, R_HAND], axis=1)
    lead = max(1, int(round(CLAP_LEAD * fps)))
    out = np.zeros(len(gap), bool)
    for i in range(1, len(gap) - 1):
        if front[i] and gap[i] < CLAP_CLOSE and gap[i] <= gap[i - 1] and gap[i] <= gap[i + 1]:
            before = gap[max(0, i - lead): i]
            if len(before) and before.max() - gap[i] > CLAP_APPROACH:
                out[max(0, i - lead): i + 1] = True
    return out


def detect_spin(positions: np.ndarray, fps: float) -> np.ndarray:
    """Frames of a spin: turning faster than ``SPIN_RATE`` within a stretch of ``SPIN_SECONDS`` whose facing
    turns more than ``SPIN_DEGREES`` while the pelvis's path on the ground is shorter than ``SPIN_TRAVEL``."""
    p = _check(positions)
    yaw = facing(p)
    w = max(1, int(round(SPIN_SECONDS * fps)))
    out = np.zeros(len(yaw), bool)
    if len(yaw) <= w:
        return out
    turn = np.abs(yaw[w:] - yaw[:-w])
    path = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p[:, PELVIS][:, [0, 2]], axis=0), axis=1))])
    fast = np.abs(np.gradient(yaw)) * fps > np.radians(SPIN_RATE)
    for s in np.flatnonzero((turn > np.radians(SPIN_DEGREES)) & (path[w:] - path[:-w] < SPIN_TRAVEL)):
        out[s: s + w + 1] |= fast[s: s + w + 1]
    return out


def detect_kick(positions: np.ndarray, fps: float) -> np.ndarray:
    """Frames of a kick: one ankle well in front of the pelvis and lifted above the other."""
    p = _check(positions)
    yaw = facing(p)
    forward = np.stack([np.sin(yaw), np.cos(yaw)], axis=1)  # (x, z) of the facing direction

    def ahead(ankle: int) -> np.ndarray:
        return np.sum((p[:, ankle][:, [0, 2]] - p[:, PELVIS][:, [0, 2]]) * forward, axis=1)

    left = (ahead(L_ANKLE) > KICK_FORWARD) & (p[:, L_ANKLE, 1] - p[:, R_ANKLE, 1] > KICK_LIFT)
    right = (ahead(R_ANKLE) > KICK_FORWARD) & (p[:, R_ANKLE, 1] - p[:, L_ANKLE, 1] > KICK_LIFT)
    return left | right


def detect_arms_up(positions: np.ndarray, fps: float) -> np.ndarray:
    """Frames with both wrists more than ``ARMS_ABOVE`` above the head and not held out in front (their
    midpoint less than ``ARMS_AHEAD`` ahead of the pelvis: raised overhead, not reaching forward)."""
    p = _check(positions)
    yaw = facing(p)
    forward = np.stack([np.sin(yaw), np.cos(yaw)], axis=1)
    middle = (p[:, L_WRIST] + p[:, R_WRIST]) / 2 - p[:, PELVIS]
    overhead = np.sum(middle[:, [0, 2]] * forward, axis=1) < ARMS_AHEAD
    head = p[:, HEAD, 1] + ARMS_ABOVE
    return (p[:, L_WRIST, 1] > head) & (p[:, R_WRIST, 1] > head) & overhead


#: move name (the synthetic dancer's names where they match) -> detector
DETECTORS: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {
    "jump": detect_jump,
    "clap": detect_clap,
    "spin": detect_spin,
    "kick": detect_kick,
    "arm-wave": detect_arms_up,
}


def detect(move: str, positions: np.ndarray, fps: float) -> np.ndarray:
    """Boolean per frame: where ``move`` (a key of :data:`DETECTORS`) is seen."""
    if move not in DETECTORS:
        raise DataError(f"move detectors: no detector for {move!r} (have: {', '.join(DETECTORS)})")
    return DETECTORS[move](positions, fps)


def second_hits(frames: np.ndarray, fps: float, start: float = 0.0, end: float | None = None) -> np.ndarray:
    """Per whole second of ``[start, end)`` (seconds), whether any frame of it is set."""
    n = len(frames)
    end = n / fps if end is None else min(end, n / fps)
    edges = np.arange(start, end - 1.0 + 1e-9, 1.0)
    return np.array([frames[int(round(t * fps)): int(round((t + 1.0) * fps))].any() for t in edges], bool)


def move_share(frames: np.ndarray, fps: float, start: float = 0.0, end: float | None = None) -> float:
    """The share of whole seconds of ``[start, end)`` in which a detection fires (NaN for none)."""
    hits = second_hits(frames, fps, start, end)
    return float(hits.mean()) if len(hits) else float("nan")
