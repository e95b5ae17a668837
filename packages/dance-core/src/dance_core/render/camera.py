"""A perspective camera for stick figures: framing from the motion's extent, a slow follow of the root."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d


@dataclass
class Camera:
    """Looks at ``target (T, 3)`` from ``distance`` at ``azimuth``/``elevation`` (radians), focal ``focal``."""

    target: np.ndarray
    distance: float
    azimuth: float = np.radians(35.0)
    elevation: float = np.radians(12.0)
    focal: float = 1.6

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Camera right, up and forward unit vectors (world Y up)."""
        ce, se = np.cos(self.elevation), np.sin(self.elevation)
        fwd = -np.array([np.sin(self.azimuth) * ce, se, np.cos(self.azimuth) * ce])
        right = np.cross(fwd, [0.0, 1.0, 0.0])
        right /= np.linalg.norm(right)
        return right, np.cross(right, fwd), fwd

    def project(self, points: np.ndarray, frame: int) -> np.ndarray:
        """Points ``(..., 3)`` to normalized image coordinates ``(..., 2)`` (x right, y up, ~[-1, 1])."""
        right, up, fwd = self.basis()
        eye = self.target[frame] - fwd * self.distance
        rel = points - eye
        depth = np.maximum(rel @ fwd, 1e-3)
        return np.stack([rel @ right, rel @ up], -1) * (self.focal / depth)[..., None]


def frame_camera(positions: np.ndarray, fps: float, follow_seconds: float = 2.0) -> Camera:
    """A camera that keeps the whole body in view and follows the root smoothly over ground."""
    root = positions[:, 0]
    size = np.ptp(positions[0], axis=0).max()
    height = float(np.percentile(positions[..., 1].max(axis=1), 90) - positions[..., 1].min())
    target = root.copy()
    win = max(1, int(follow_seconds * fps))
    target[:, [0, 2]] = uniform_filter1d(root[:, [0, 2]], win, axis=0, mode="nearest")
    target[:, 1] = positions[..., 1].min() + 0.5 * height
    wander = np.linalg.norm(root[:, [0, 2]] - target[:, [0, 2]], axis=-1).max()
    return Camera(target, distance=1.45 * max(height, size) + 1.5 * wander + 1e-6)
