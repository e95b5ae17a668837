"""Root representations: absolute, and Transflower's ground-projected deltas with an exact inverse.

Deltas per frame ``t``: ``dx, dz`` (the root's ground displacement from ``t-1`` to ``t`` in the heading
frame of ``t-1``), the root height ``y``, ``dyaw`` (heading change from ``t-1`` to ``t``, radians),
and the root rotation relative to the heading frame. Frame 0 has zero deltas; integrating from
the start position and heading reproduces the trajectory exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dance_core.motion.rotations import quat_conj, quat_mul, quat_rotate, yaw_quat

DELTA_CHANNELS = ("root.dx", "root.dz", "root.y", "root.dyaw")


def heading(rotation: np.ndarray) -> np.ndarray:
    """Yaw in radians of the root's forward (+Z) axis projected on the ground, ``(T,)``."""
    fwd = quat_rotate(rotation, np.array([0.0, 0.0, 1.0]))
    return np.arctan2(fwd[..., 0], fwd[..., 2])


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to ``[-pi, pi)``."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


@dataclass
class RootStart:
    """Where integration of deltas starts: ground position and heading of frame 0."""

    x: float = 0.0
    z: float = 0.0
    yaw: float = 0.0


def root_to_deltas(position: np.ndarray, rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray, RootStart]:
    """``(T, 3)`` positions and ``(T, 4)`` root quaternions to deltas ``(T, 4)``, heading-relative
    root rotations ``(T, 4)`` and the start state that :func:`deltas_to_root` needs to invert exactly."""
    position = np.asarray(position, np.float64)
    yaw = heading(rotation)
    h = yaw_quat(yaw)
    local = quat_mul(quat_conj(h), rotation)
    out = np.zeros((len(position), 4))
    out[:, 2] = position[:, 1]
    if len(position) > 1:
        step = position[1:] - position[:-1]
        step[:, 1] = 0.0
        rel = quat_rotate(quat_conj(h[:-1]), step)
        out[1:, 0], out[1:, 1] = rel[:, 0], rel[:, 2]
        out[1:, 3] = wrap(np.diff(yaw))
    start = RootStart(float(position[0, 0]), float(position[0, 2]), float(yaw[0])) if len(position) else RootStart()
    return out, local, start


def deltas_to_root(
    deltas: np.ndarray, local: np.ndarray, start: RootStart | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Integrate deltas back to world root positions ``(T, 3)`` and rotations ``(T, 4)``."""
    start = start or RootStart()
    deltas = np.asarray(deltas, np.float64)
    yaw = start.yaw + np.cumsum(np.concatenate([[0.0], deltas[1:, 3]]))
    h = yaw_quat(yaw)
    step = np.zeros((len(deltas), 3))
    step[:, 0], step[:, 2] = deltas[:, 0], deltas[:, 1]
    world_step = np.zeros_like(step)
    world_step[1:] = quat_rotate(h[:-1], step[1:])
    position = np.cumsum(world_step, axis=0) + np.array([start.x, 0.0, start.z])
    position[:, 1] = deltas[:, 2]
    return position, quat_mul(h, np.asarray(local, np.float64))
