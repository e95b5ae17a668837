"""AIST++ / SMPL motion pickles: ``smpl_poses (T, 72)`` axis-angle, ``smpl_trans (T, 3)``, optional
``smpl_scaling``. The joint positions come from the user's own SMPL body model file (the ``model``
option, else ``DANCE_SMPL_MODEL``, which ``--smpl-model`` sets): its rest joints at zero shape, as
:mod:`dance_core.formats.smpl_model` reads them. No body is guessed without one: SMPL rotations on
other proportions would put the joints in the wrong places."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import atomic_path
from dance_core.errors import DataError
from dance_core.formats.smpl_model import load_body_model, missing_model, model_from_env
from dance_core.formats.unpickle import safe_load
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat, quat_to_expmap, unroll_quat
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import SMPL_NAMES, SMPL_PARENTS
from dance_core.protocols import MotionData


def _array(data: dict, key: str, path: Path, cols: int) -> np.ndarray:
    if key not in data:
        raise DataError(f"{path}: {key}: missing (AIST++ motion needs smpl_poses and smpl_trans)")
    arr = np.asarray(data[key], dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != cols or not np.isfinite(arr).all():
        raise DataError(f"{path}: {key}: expected finite (frames, {cols}), got {arr.shape}")
    return arr


class SmplFormat:
    """The ``smpl`` format: AIST++ pickles read with a restricted unpickler, on the skeleton of the
    SMPL body model ``model`` (a ``.pkl`` or ``.npz`` path; None: ``DANCE_SMPL_MODEL``)."""

    def __init__(self, fps: float = 60.0, trans_scale: float | None = None, model: str | Path | None = None):
        self.fps, self.trans_scale, self.model = fps, trans_scale, model

    def model_path(self) -> str | None:
        """The SMPL model file this format reads with: its ``model``, else ``DANCE_SMPL_MODEL``, else None."""
        return str(self.model) if self.model else model_from_env()

    def read_motion(self, path: str | Path) -> Motion:
        """The SMPL-24 motion in a pickle on the model's skeleton (translation in metres:
        ``smpl_trans / smpl_scaling``, added to the model's rest pelvis, as SMPL does)."""
        path = Path(path)
        model = self.model_path()
        if model is None:  # before reading anything
            raise missing_model(path)
        data = safe_load(path)
        if not isinstance(data, dict):
            raise DataError(f"{path}: expected a dict of arrays, got {type(data).__name__}")
        poses = _array(data, "smpl_poses", path, 72)
        trans = _array(data, "smpl_trans", path, 3)
        if len(poses) != len(trans):
            raise DataError(f"{path}: smpl_poses has {len(poses)} frames, smpl_trans {len(trans)}")
        scaling = float(np.asarray(data.get("smpl_scaling", [1.0]), np.float64).reshape(-1)[0])
        if not scaling > 0:
            raise DataError(f"{path}: smpl_scaling must be positive, got {scaling}")
        scale = self.trans_scale if self.trans_scale is not None else 1.0 / scaling
        skel = load_body_model(model).skeleton()
        rot = unroll_quat(expmap_to_quat(poses.reshape(-1, 24, 3)))
        return Motion(skel, self.fps, skel.offsets[0] + trans * scale, rot, meta={"smpl_scaling": scaling})

    def read(self, path: str | Path) -> MotionData:
        """Poses and translation as the frame array ``(T, 75)``, with the skeletal motion attached."""
        motion = self.read_motion(path)
        values = np.concatenate([quat_to_expmap(motion.rotations).reshape(motion.n_frames, -1),
                                 motion.root - motion.skeleton.offsets[0]], axis=1)
        channels = [f"{n}.{a}" for n in motion.skeleton.names for a in "xyz"] + ["trans.x", "trans.y", "trans.z"]
        return MotionData(values.astype(np.float32), motion.fps, channels, {"path": str(path)}, motion)

    def write_motion(self, motion: Motion, path: str | Path) -> None:
        """Write an SMPL-24 motion as an AIST++ pickle (plain dict of float32 arrays). ``smpl_trans`` is
        the root less the SMPL model's rest pelvis, so SMPL puts the pelvis where the motion has it: the
        model's, or (none given) that of a motion read from an SMPL model."""
        ref = Skeleton(list(SMPL_NAMES), list(SMPL_PARENTS), np.zeros((len(SMPL_NAMES), 3)), name="smpl24")
        motion = motion.conformed(ref, str(path))
        if motion.rotations is None:
            raise DataError(f"{path}: SMPL pickles need joint rotations; this motion only has positions")
        model = self.model_path()
        if model is not None:
            pelvis = load_body_model(model).joints[0]
        elif motion.skeleton.name == "smpl24":  # read from an SMPL model: its root offset is the model's pelvis
            pelvis = motion.skeleton.offsets[0]
        else:
            raise missing_model(path)
        scaling = float(motion.meta.get("smpl_scaling", 1.0))
        scale = self.trans_scale if self.trans_scale is not None else 1.0 / scaling
        data = {
            "smpl_poses": quat_to_expmap(motion.rotations).reshape(motion.n_frames, 72).astype(np.float32),
            "smpl_trans": ((motion.root - pelvis) / scale).astype(np.float32),
            "smpl_scaling": np.array([scaling], np.float32),
        }
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            pickle.dump(data, fh, protocol=4)

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write the skeletal motion behind ``motion``."""
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: an SMPL pickle needs a skeletal motion; this one has only feature values")
        self.write_motion(motion.skeleton_motion, path)


def build(config: Any = None, **_: Any) -> SmplFormat:
    """Build the ``smpl`` format."""
    return SmplFormat(getattr(config, "fps", 60.0), getattr(config, "trans_scale", None),
                      getattr(config, "model", None))
