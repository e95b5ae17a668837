"""Joint-position arrays: HumanML3D ``new_joints`` ``(T, 22, 3)`` NumPy files (SMPL's first 22 joints)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import atomic_path
from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import dance24
from dance_core.protocols import MotionData

HUMANML_JOINTS = 22


def smpl22() -> Skeleton:
    """SMPL without the two hand joints: HumanML3D's 22-joint skeleton."""
    s = dance24()
    return Skeleton(s.names[:HUMANML_JOINTS], s.parents[:HUMANML_JOINTS], s.offsets[:HUMANML_JOINTS], name="smpl22")


class JointsFormat:
    """The ``joints`` format: ``.npy`` arrays of world joint positions (no pickle)."""

    def __init__(self, fps: float = 20.0):
        self.fps = fps

    def read_motion(self, path: str | Path) -> Motion:
        """A positions-only motion on the 22-joint skeleton."""
        path = Path(path)
        try:
            arr = np.load(path, allow_pickle=False)
        except FileNotFoundError:
            raise DataError(f"{path}: motion file not found") from None
        except (OSError, ValueError) as exc:
            raise DataError(f"{path}: not a NumPy array file ({exc})") from None
        if arr.ndim != 3 or arr.shape[1:] != (HUMANML_JOINTS, 3) or len(arr) == 0:
            raise DataError(f"{path}: expected joint positions (frames, {HUMANML_JOINTS}, 3), got {arr.shape}")
        if not np.isfinite(arr).all():
            raise DataError(f"{path}: joint positions contain NaN or inf")
        arr = arr.astype(np.float64)
        return Motion(smpl22(), self.fps, arr[:, 0], joint_positions=arr)

    def read(self, path: str | Path) -> MotionData:
        """Flattened positions ``(T, 66)`` with the motion attached."""
        m = self.read_motion(path)
        channels = [f"{n}.{a}" for n in m.skeleton.names for a in "xyz"]
        return MotionData(m.joint_positions.reshape(m.n_frames, -1).astype(np.float32), m.fps, channels,
                          {"path": str(path)}, m)

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write world positions of the skeletal motion (first 22 joints of SMPL order)."""
        m = motion.skeleton_motion
        if m is None:
            raise DataError(f"{path}: joint arrays need a skeletal motion; this one has only feature values")
        pos = m.positions()
        if len(m.skeleton) == 24 and m.skeleton.names[:HUMANML_JOINTS] == smpl22().names:
            pos = pos[:, :HUMANML_JOINTS]
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.save(fh, pos.astype(np.float32))


def build(config: Any = None, **_: Any) -> JointsFormat:
    """Build the ``joints`` format."""
    return JointsFormat(getattr(config, "fps", 20.0))
