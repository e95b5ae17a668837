"""Synthetic SMPL-like body models for tests, in SMPL's file layouts (``.npz``; a Python-2-style
pickle with chumpy-like arrays and a SciPy sparse ``J_regressor``). Their numbers are random around a
made-up stick figure: nothing here comes from SMPL's model (licensed by its authors)."""

from __future__ import annotations

import contextlib
import pickle
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from dance_core.formats.smpl_model import ENV_MODEL
from dance_core.motion.skeletons import SMPL_NAMES, SMPL_PARENTS

#: a made-up standing body (metres, Y up, +X the body's left), round numbers of our own
_BODY = {
    "Pelvis": (0, 0.95, 0), "Spine1": (0, 1.05, 0), "Spine2": (0, 1.15, 0), "Spine3": (0, 1.25, 0),
    "Neck": (0, 1.45, 0), "Head": (0, 1.6, 0.02),
}
for _side, _s in (("L", 1), ("R", -1)):
    _BODY |= {
        f"{_side}_Hip": (_s * 0.09, 0.9, 0), f"{_side}_Knee": (_s * 0.09, 0.5, 0.01),
        f"{_side}_Ankle": (_s * 0.09, 0.08, -0.02), f"{_side}_Foot": (_s * 0.09, 0.02, 0.12),
        f"{_side}_Collar": (_s * 0.05, 1.4, 0), f"{_side}_Shoulder": (_s * 0.18, 1.4, 0),
        f"{_side}_Elbow": (_s * 0.45, 1.4, 0), f"{_side}_Wrist": (_s * 0.7, 1.4, 0),
        f"{_side}_Hand": (_s * 0.78, 1.4, 0),
    }
BODY = np.array([_BODY[n] for n in SMPL_NAMES], float)
#: SMPL's kinematic tree as its files store it: parents over joint ids, the root's parent uint32 -1
KINTREE = np.array([[2**32 - 1, *SMPL_PARENTS[1:]], list(range(24))], np.int64)


def synthetic_model(seed: int = 0, per_joint: int = 12) -> dict[str, np.ndarray]:
    """``v_template`` (24 * per_joint vertices: a noisy cluster around each made-up joint), a random
    row-normalised ``J_regressor`` (each joint weighs its cluster and a few other vertices),
    ``kintree_table`` and a random ``shapedirs``."""
    rng = np.random.default_rng(seed)
    n = 24 * per_joint
    v_template = np.repeat(BODY, per_joint, axis=0) + rng.normal(scale=0.02, size=(n, 3))
    regressor = np.zeros((24, n))
    for j in range(24):
        regressor[j, j * per_joint : (j + 1) * per_joint] = rng.random(per_joint) + 0.1
        regressor[j, rng.choice(n, 3, replace=False)] += rng.random(3) * 0.01
    regressor /= regressor.sum(axis=1, keepdims=True)
    shapedirs = rng.normal(scale=1e-3, size=(n, 3, 10))
    return {"v_template": v_template, "J_regressor": regressor, "kintree_table": KINTREE.copy(),
            "shapedirs": shapedirs}


def write_npz(path: Path, model: dict[str, np.ndarray]) -> Path:
    """The model as an ``.npz`` of plain arrays."""
    np.savez(path, **model)
    return path


@contextlib.contextmanager
def fake_chumpy():
    """A stand-in ``chumpy.ch`` module while pickling, so that objects pickle as chumpy's ``Ch`` does
    (protocol 2: the class by name, then its state: the array ``x`` beside chumpy's bookkeeping)."""

    class Ch:
        def __init__(self, x):
            self.x = np.asarray(x, np.float64)

        def __getstate__(self):
            return {"x": self.x, "_dirty_vars": {"x"}, "_itr": None, "_depends_on_deps": {},
                    "_make_dense": False, "_make_sparse": False}

    Ch.__module__, Ch.__qualname__ = "chumpy.ch", "Ch"
    package, module = types.ModuleType("chumpy"), types.ModuleType("chumpy.ch")
    module.Ch, package.ch = Ch, module
    saved = {k: sys.modules.get(k) for k in ("chumpy", "chumpy.ch")}
    sys.modules.update({"chumpy": package, "chumpy.ch": module})
    try:
        yield Ch
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v


def write_pkl(path: Path, model: dict[str, np.ndarray], chumpy: bool = True, sparse: bool = True) -> Path:
    """The model as a protocol-2 pickle shaped like SMPL's: a dict whose ``v_template`` and
    ``shapedirs`` are chumpy arrays (``chumpy=True``) and whose ``J_regressor`` is a SciPy
    ``csc_matrix`` (``sparse=True``), beside plain arrays and strings."""
    import scipy.sparse

    data = dict(model)
    data |= {"f": np.arange(30, dtype=np.uint32).reshape(10, 3), "bs_style": "lbs", "bs_type": "lrotmin"}
    if sparse and "J_regressor" in model:
        data["J_regressor"] = scipy.sparse.csc_matrix(model["J_regressor"])
    with fake_chumpy() as Ch:
        for key in ("v_template", "shapedirs"):
            if chumpy and key in model:
                data[key] = Ch(model[key])
        path.write_bytes(pickle.dumps(data, protocol=2))
    return path


def rest_joints(model: dict[str, np.ndarray]) -> np.ndarray:
    """What the reader must find: ``J_regressor @ v_template``."""
    return model["J_regressor"] @ model["v_template"]


@pytest.fixture
def smpl_model(tmp_path, monkeypatch) -> Path:
    """A synthetic model file named by ``DANCE_SMPL_MODEL`` for the test (as ``--smpl-model`` does)."""
    path = write_npz(tmp_path / "synthetic_smpl.npz", synthetic_model())
    monkeypatch.setenv(ENV_MODEL, str(path))
    return path
