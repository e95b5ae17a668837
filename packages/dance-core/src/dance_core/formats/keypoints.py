"""2D keypoints in OpenPose BODY_25 order, as JSON: ``{"fps", "keypoints": (T, 25, 2|3)}`` (x, y[,
confidence]) or DanceRevolution's ``{"dance_array": (T, 50)}``. Image y points down; the motion's
y points up, so y is negated (and everything multiplied by ``scale``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import write_text
from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.skeletons import BODY25_ORDER, body25
from dance_core.protocols import MotionData


class KeypointsFormat:
    """The ``keypoints`` format (``.json``)."""

    def __init__(self, fps: float = 30.0, scale: float = 1.0):
        self.fps, self.scale = fps, scale

    def read_motion(self, path: str | Path) -> Motion:
        """A positions-only motion on the BODY_25 tree (z = 0)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise DataError(f"{path}: motion file not found") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise DataError(f"{path}: not JSON ({exc})") from None
        if not isinstance(data, dict):
            raise DataError(f"{path}: expected a JSON object with 'keypoints' or 'dance_array'")
        key = "keypoints" if "keypoints" in data else "dance_array"
        try:
            arr = np.asarray(data[key], dtype=np.float64)
        except KeyError:
            raise DataError(f"{path}: keypoints: missing (or dance_array)") from None
        except (TypeError, ValueError):
            raise DataError(f"{path}: {key}: not a numeric array") from None
        if key == "dance_array":
            arr = arr.reshape(len(arr), -1, 2) if arr.ndim == 2 else arr
        if arr.ndim != 3 or arr.shape[1] != 25 or arr.shape[2] not in (2, 3) or len(arr) == 0:
            raise DataError(f"{path}: {key}: expected (frames, 25, 2 or 3), got {arr.shape}")
        fps = float(data.get("fps", self.fps))
        skel = body25()
        order = [BODY25_ORDER.index(n) for n in skel.names]
        pos = np.zeros((len(arr), 25, 3))
        pos[..., 0] = arr[:, order, 0] * self.scale
        pos[..., 1] = -arr[:, order, 1] * self.scale
        meta = {"confidence": arr[:, order, 2]} if arr.shape[2] == 3 else {}
        return Motion(skel, fps, pos[:, 0], joint_positions=pos, meta=meta)

    def read(self, path: str | Path) -> MotionData:
        """Flattened x, y per keypoint ``(T, 50)`` (tree order) with the motion attached."""
        m = self.read_motion(path)
        channels = [f"{n}.{a}" for n in m.skeleton.names for a in "xy"]
        return MotionData(m.joint_positions[..., :2].reshape(m.n_frames, -1).astype(np.float32), m.fps,
                          channels, {"path": str(path)}, m)

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write BODY_25 keypoints in OpenPose order (a skeletal motion on the BODY_25 tree)."""
        m = motion.skeleton_motion
        if m is None or sorted(m.skeleton.names) != sorted(BODY25_ORDER):
            raise DataError(f"{path}: 2D keypoints need a motion on the BODY_25 skeleton")
        pos = m.positions()
        idx = [m.skeleton.names.index(n) for n in BODY25_ORDER]
        xy = np.stack([pos[:, idx, 0], -pos[:, idx, 1]], -1) / self.scale
        write_text(path, json.dumps({"fps": m.fps, "format": "BODY_25", "keypoints": xy.round(5).tolist()}))


def build(config: Any = None, **_: Any) -> KeypointsFormat:
    """Build the ``keypoints`` format."""
    return KeypointsFormat(getattr(config, "fps", 30.0), getattr(config, "scale", 1.0))
