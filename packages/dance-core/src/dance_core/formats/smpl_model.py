"""SMPL body models, the user's own file: the rest joints that AIST++ pose parameters rotate.

SMPL's model files are licensed by their authors (https://smpl.is.tue.mpg.de) and none ships with
this project. A model is read from the original ``.pkl`` (a Python 2 pickle holding chumpy arrays and
a SciPy sparse ``J_regressor``, read by the restricted unpickler, which imports neither package) or
from an ``.npz`` with ``v_template (V, 3)``, ``J_regressor (24, V)``, ``kintree_table (2, 24)`` and,
optionally, ``shapedirs (V, 3, betas)``. The joints at rest are ``J_regressor @ v_template``: the
zero shape, as AIST++ gives no shape parameters. Each file is read once per process (cached by path,
modification time and size).
"""

from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from dance_core.errors import DataError
from dance_core.formats.unpickle import safe_load
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import SMPL_NAMES, SMPL_PARENTS

#: environment variable naming the SMPL model file (``--smpl-model`` sets it for the command it runs)
ENV_MODEL = "DANCE_SMPL_MODEL"
#: the model files read
SUFFIXES = (".pkl", ".npz")
#: where a model comes from, for messages
WHERE = "SMPL_NEUTRAL.pkl or .npz from smpl.is.tue.mpg.de; licensed by its authors"


def missing_model(path: str | Path) -> DataError:
    """The one-line error for an AIST++ file read with no SMPL model given."""
    return DataError(
        f"{path}: AIST++ SMPL parameters need an SMPL body model for the joint positions: pass --smpl-model PATH "
        f"({WHERE}) or set the smpl format's `model` option (or {ENV_MODEL})"
    )


def model_from_env() -> str | None:
    """The model file named by :data:`ENV_MODEL`, or None."""
    return os.environ.get(ENV_MODEL) or None


@dataclass(frozen=True)
class BodyModel:
    """What a skeleton needs of an SMPL model: its 24 rest joints (metres, SMPL's order) and vertex count."""

    path: str
    joints: np.ndarray
    n_vertices: int

    def skeleton(self) -> Skeleton:
        """SMPL's 24-joint tree with this model's rest offsets (each joint minus its parent; the root's
        offset is its rest position)."""
        parents = np.array(SMPL_PARENTS)
        offsets = self.joints - np.where(parents[:, None] >= 0, self.joints[np.maximum(parents, 0)], 0.0)
        return Skeleton(list(SMPL_NAMES), list(SMPL_PARENTS), offsets, units="m", name="smpl24")


def load_body_model(path: str | Path) -> BodyModel:
    """The SMPL model in ``path`` (``.pkl`` or ``.npz``), read once per file version; a bad file or
    field is one ``DataError`` line naming them."""
    p = Path(path).expanduser()
    try:
        st = p.stat()
    except FileNotFoundError:
        raise DataError(f"{p}: SMPL model file not found ({WHERE})") from None
    except OSError as exc:
        raise DataError(f"{p}: SMPL model file cannot be read ({exc.strerror or exc})") from None
    if not p.is_file():
        raise DataError(f"{p}: SMPL model file is a folder, not a file")
    if p.suffix.lower() not in SUFFIXES:
        raise DataError(f"{p}: an SMPL model file is .pkl or .npz, not {p.suffix or 'a file without a suffix'!r}")
    return _load(str(p.resolve()), st.st_mtime_ns, st.st_size)


@lru_cache(maxsize=4)
def _load(path: str, mtime_ns: int, size: int) -> BodyModel:
    """Read and check one model file version (the cache key holds its time and size)."""
    fields = _read_pkl(path) if path.lower().endswith(".pkl") else _read_npz(path)
    template = _float(fields, "v_template", path)
    if template.ndim != 2 or template.shape[1] != 3 or len(template) == 0:
        raise DataError(f"{path}: v_template: expected (vertices, 3), got {template.shape}")
    n = len(template)
    regressor = _float(fields, "J_regressor", path)
    if regressor.shape != (len(SMPL_NAMES), n):
        raise DataError(f"{path}: J_regressor: expected ({len(SMPL_NAMES)}, {n}) (SMPL's joints by the template's "
                        f"vertices), got {regressor.shape}")
    if "shapedirs" in fields:
        shapedirs = _float(fields, "shapedirs", path)
        if shapedirs.ndim != 3 or shapedirs.shape[:2] != (n, 3):
            raise DataError(f"{path}: shapedirs: expected ({n}, 3, betas), got {shapedirs.shape}")
    _check_tree(fields, path)
    joints = regressor @ template
    joints.setflags(write=False)
    return BodyModel(path, joints, n)


def _read_pkl(path: str) -> dict:
    data = safe_load(path, "SMPL model file")
    if not isinstance(data, dict):
        raise DataError(f"{path}: expected an SMPL model (a dict of arrays), got {type(data).__name__}")
    return data


def _read_npz(path: str) -> dict:
    try:
        npz = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise DataError(f"{path}: not a readable .npz file ({exc})") from None
    if not hasattr(npz, "files"):
        raise DataError(f"{path}: expected an .npz archive of named arrays, got a single array")
    out = {}
    with npz:
        for key in (k for k in npz.files if k in ("v_template", "J_regressor", "kintree_table", "shapedirs")):
            try:
                out[key] = npz[key]
            except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:  # object arrays need pickle
                raise DataError(f"{path}: {key}: not a plain array ({exc})") from None
    return out


def _float(fields: dict, key: str, path: str) -> np.ndarray:
    if key not in fields:
        raise DataError(f"{path}: {key}: missing (an SMPL model has v_template, J_regressor and kintree_table)")
    try:
        arr = np.asarray(fields[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise DataError(f"{path}: {key}: not a numeric array ({type(fields[key]).__name__})") from None
    if not np.isfinite(arr).all():
        raise DataError(f"{path}: {key}: holds NaN or inf")
    return arr


def _check_tree(fields: dict, path: str) -> None:
    """``kintree_table`` (parent ids over joint ids) must be SMPL's 24-joint tree."""
    if "kintree_table" not in fields:
        raise DataError(f"{path}: kintree_table: missing (an SMPL model has v_template, J_regressor and kintree_table)")
    try:
        table = np.asarray(fields["kintree_table"])
        ok = table.dtype.kind in "iuf" and table.shape == (2, len(SMPL_NAMES))
        table = table.astype(np.int64) if ok else table
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        shape = getattr(fields["kintree_table"], "shape", type(fields["kintree_table"]).__name__)
        raise DataError(f"{path}: kintree_table: expected integers (2, {len(SMPL_NAMES)}), got {shape}")
    parents, ids = table
    if sorted(ids.tolist()) != list(range(len(SMPL_NAMES))):
        raise DataError(f"{path}: kintree_table: row 1 must number the joints 0-{len(SMPL_NAMES) - 1}")
    parent_of = dict(zip(ids.tolist(), parents.tolist(), strict=True))
    for j in range(1, len(SMPL_NAMES)):
        if parent_of[j] != SMPL_PARENTS[j]:
            raise DataError(f"{path}: kintree_table: joint {j} ({SMPL_NAMES[j]}) has parent {parent_of[j]}, SMPL's "
                            f"is {SMPL_PARENTS[j]}: not SMPL's 24-joint body (SMPL+H and SMPL-X are not read)")
    if 0 <= parent_of[0] < len(SMPL_NAMES):
        raise DataError(f"{path}: kintree_table: the root (joint 0) has parent {parent_of[0]}; SMPL's has none")
