"""AIST++ pickles on the user's own SMPL model: rest joints from J_regressor @ v_template, FK, one-line
errors, and the restricted unpickler's chumpy / SciPy stand-ins. Every model here is synthetic."""

import os
import pickle
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dance_core.cli.main import main
from dance_core.data.files import read_motion_file
from dance_core.errors import DataError
from dance_core.formats.configs import SmplFormatConfig
from dance_core.formats.smpl import SmplFormat
from dance_core.formats.smpl_model import ENV_MODEL, load_body_model
from dance_core.formats.unpickle import safe_load
from dance_core.formats.wav import write_wav
from dance_core.motion.skeletons import SMPL_PARENTS
from dance_core.recipe.schema import resolve_paths
from dance_core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
from smpl_model_helpers import (  # noqa: E402, F401 - smpl_model is a fixture
    KINTREE,
    fake_chumpy,
    rest_joints,
    smpl_model,
    synthetic_model,
    write_npz,
    write_pkl,
)


def aist_pickle(path, frames=20, seed=1, scaling=93.0):
    """An AIST++-style motion pickle: random axis-angle poses, a drifting translation, a scaling."""
    rng = np.random.default_rng(seed)
    data = {
        "smpl_poses": (rng.normal(scale=0.4, size=(frames, 72))).astype(np.float32),
        "smpl_trans": (np.cumsum(rng.normal(size=(frames, 3)), axis=0) * 5.0).astype(np.float32),
        "smpl_scaling": np.array([scaling], np.float32),
    }
    path.write_bytes(pickle.dumps(data, protocol=4))
    return data


def expected_positions(joints, data):
    """FK written out with SciPy rotations: SMPL's pelvis at its rest joint plus trans / scaling, each
    child at its parent plus the parent's world rotation of the rest bone."""
    poses = data["smpl_poses"].astype(np.float64).reshape(-1, 24, 3)
    trans = data["smpl_trans"].astype(np.float64) / float(data["smpl_scaling"][0])
    out = np.zeros((len(poses), 24, 3))
    for t in range(len(poses)):
        world = [None] * 24
        for j in range(24):
            local = Rotation.from_rotvec(poses[t, j])
            p = SMPL_PARENTS[j]
            if p < 0:
                world[j], out[t, j] = local, joints[0] + trans[t]
            else:
                world[j] = world[p] * local
                out[t, j] = out[t, p] + world[p].apply(joints[j] - joints[p])
    return out


@pytest.mark.parametrize("kind", ["npz", "pkl-chumpy-sparse", "pkl-plain-sparse", "pkl-plain-dense"])
def test_rest_joints_are_the_regressor_times_the_template(tmp_path, kind):
    model = synthetic_model(seed=3)
    if kind == "npz":
        path = write_npz(tmp_path / "m.npz", model)
    else:
        path = write_pkl(tmp_path / "m.pkl", model, chumpy="chumpy" in kind, sparse="-sparse" in kind)
    body = load_body_model(path)
    assert "chumpy" not in sys.modules  # read without chumpy (the fake is gone after pickling)
    np.testing.assert_allclose(body.joints, rest_joints(model), atol=1e-12)
    skel = body.skeleton()
    assert skel.parents == SMPL_PARENTS and body.n_vertices == len(model["v_template"])
    np.testing.assert_allclose(skel.rest_positions(), rest_joints(model), atol=1e-12)


def test_any_vertex_count_and_a_cache_per_file_version(tmp_path):
    path = write_npz(tmp_path / "m.npz", synthetic_model(seed=1, per_joint=5))
    first = load_body_model(path)
    assert first.n_vertices == 120 and load_body_model(str(path)) is first  # cached
    other = synthetic_model(seed=2, per_joint=7)
    time.sleep(0.01)
    write_npz(tmp_path / "m.npz", other)
    os.utime(path, ns=(time.time_ns(), time.time_ns() + 10**9))  # surely a new modification time
    again = load_body_model(path)
    assert again is not first and again.n_vertices == 168
    np.testing.assert_allclose(again.joints, rest_joints(other), atol=1e-12)


@pytest.mark.parametrize("kind", ["npz", "pkl"])
def test_aist_motion_forward_kinematics_on_the_model(tmp_path, kind, monkeypatch):
    model = synthetic_model(seed=5)
    path = (write_npz if kind == "npz" else write_pkl)(tmp_path / f"m.{kind}", model)
    data = aist_pickle(tmp_path / "dance.pkl")
    motion = SmplFormat(model=path).read_motion(tmp_path / "dance.pkl")
    assert motion.skeleton.name == "smpl24" and motion.fps == 60.0 and motion.n_frames == 20
    np.testing.assert_allclose(motion.positions(), expected_positions(rest_joints(model), data), atol=1e-5)
    monkeypatch.setenv(ENV_MODEL, str(path))  # the registry's default format reads the same through the env
    read = read_motion_file(tmp_path / "dance.pkl", get_registry())
    np.testing.assert_allclose(read.skeleton_motion.positions(), motion.positions(), atol=1e-9)
    np.testing.assert_allclose(read.values[:, 72:], data["smpl_trans"] / 93.0, atol=1e-6)


@pytest.mark.usefixtures("smpl_model")
def test_write_then_read_keeps_the_motion(tmp_path):
    aist_pickle(tmp_path / "dance.pkl")
    fmt = SmplFormat()
    motion = fmt.read_motion(tmp_path / "dance.pkl")
    fmt.write_motion(motion, tmp_path / "back.pkl")
    np.testing.assert_allclose(fmt.read_motion(tmp_path / "back.pkl").positions(), motion.positions(), atol=1e-4)


def test_a_missing_model_is_one_line_before_the_motion_is_read(tmp_path, monkeypatch):
    monkeypatch.delenv(ENV_MODEL, raising=False)
    aist_pickle(tmp_path / "dance.pkl")
    for read in (lambda: SmplFormat().read(tmp_path / "dance.pkl"),
                 lambda: read_motion_file(tmp_path / "dance.pkl", get_registry()),
                 lambda: SmplFormat().read(tmp_path / "not-even-there.pkl")):
        with pytest.raises(DataError) as info:
            read()
        text = str(info.value)
        assert "\n" not in text and ".pkl: AIST++ SMPL parameters need an SMPL body model" in text
        assert "--smpl-model PATH" in text and "`model` option" in text


def test_the_cli_takes_smpl_model_and_stops_without_it(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv(ENV_MODEL, raising=False)  # restored after the test, whatever main() sets
    aist_pickle(tmp_path / "dance.pkl")
    out = tmp_path / "d.html"
    assert main(["-q", "render", str(tmp_path / "dance.pkl"), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "dance.pkl: AIST++ SMPL parameters need an SMPL body model" in err[0]
    model = write_npz(tmp_path / "m.npz", synthetic_model())
    assert main(["-q", "render", str(tmp_path / "dance.pkl"), "-o", str(out), "--smpl-model", str(model)]) == 0
    assert out.is_file() and os.environ[ENV_MODEL] == str(model.resolve())
    for bad, why in ((tmp_path / "none.npz", "SMPL model file not found"), (tmp_path / "dance.wav", "ends in")):
        if bad.suffix == ".wav":
            bad.write_bytes(b"RIFF")
        assert main(["-q", "render", str(tmp_path / "dance.pkl"), "-o", str(out), "--smpl-model", str(bad)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"--smpl-model {bad}" in err[0] and why in err[0]


def test_compose_and_evaluate_stop_before_any_work_without_a_model(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv(ENV_MODEL, raising=False)
    aist_pickle(tmp_path / "dance.pkl")
    write_wav(tmp_path / "song.wav", np.zeros(8000, np.float32), 8000)
    (tmp_path / "fake.safetensors").write_bytes(b"not a checkpoint")  # never opened: the seed stops first
    rc = main(["-q", "compose", "core-synthetic", "--music", str(tmp_path / "song.wav"), "--checkpoint",
               str(tmp_path / "fake.safetensors"), "--seed-motion", str(tmp_path / "dance.pkl"), "-o",
               str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "dance.pkl: AIST++ SMPL parameters need" in err[0], err
    (tmp_path / "gen").mkdir()
    aist_pickle(tmp_path / "gen" / "dance.pkl")
    rc = main(["-q", "evaluate", "--generated", str(tmp_path / "gen"), "--reference", str(tmp_path / "gen"),
               "-o", str(tmp_path / "r.json"), "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "dance.pkl: AIST++ SMPL parameters need" in err[0], err
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"PK not really")
    rc = main(["-q", "evaluate", "--generated", str(tmp_path / "gen"), "--reference", str(tmp_path / "gen"),
               "-o", str(tmp_path / "r.json"), "--no-plots", "--smpl-model", str(broken)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "broken.npz: not a readable .npz file" in err[0], err


def _bad(model, key, value):
    return {**model, key: value}


@pytest.mark.parametrize("change, match", [
    (lambda m: _bad(m, "v_template", m["v_template"][:, :2]), r"v_template: expected \(vertices, 3\)"),
    (lambda m: _bad(m, "J_regressor", m["J_regressor"][:23]), r"J_regressor: expected \(24, 288\)"),
    (lambda m: _bad(m, "J_regressor", m["J_regressor"][:, :-1]), r"J_regressor: expected \(24, 288\)"),
    (lambda m: _bad(m, "shapedirs", m["shapedirs"][:-1]), r"shapedirs: expected \(288, 3, betas\)"),
    (lambda m: _bad(m, "v_template", np.full_like(m["v_template"], np.nan)), "v_template: holds NaN"),
    (lambda m: {k: v for k, v in m.items() if k != "J_regressor"}, "J_regressor: missing"),
    (lambda m: {k: v for k, v in m.items() if k != "kintree_table"}, "kintree_table: missing"),
    (lambda m: _bad(m, "kintree_table", KINTREE[:, :22]), r"kintree_table: expected integers \(2, 24\)"),
    (lambda m: _bad(m, "kintree_table", np.array([[2**32 - 1, *SMPL_PARENTS[1:4], 0, *SMPL_PARENTS[5:]],
                                                 list(range(24))])), "joint 4 .L_Knee. has parent 0, SMPL's is 1"),
    (lambda m: _bad(m, "kintree_table", np.array([[0, *SMPL_PARENTS[1:]], list(range(24))])), "root .joint 0."),
])
@pytest.mark.parametrize("kind", ["npz", "pkl"])
def test_bad_models_name_the_file_and_key(tmp_path, kind, change, match):
    path = (write_npz if kind == "npz" else write_pkl)(tmp_path / f"bad.{kind}", change(synthetic_model()))
    with pytest.raises(DataError, match=match) as info:
        load_body_model(path)
    assert str(path.name) in str(info.value) and "\n" not in str(info.value)


def test_unreadable_model_files_are_one_line(tmp_path):
    np.savez(tmp_path / "obj.npz", v_template=np.array([object()]), J_regressor=np.zeros((24, 1)))
    (tmp_path / "list.pkl").write_bytes(pickle.dumps([1, 2]))
    (tmp_path / "model.obj").write_text("v 0 0 0\n")
    np.save(tmp_path / "single.npy", np.zeros(3))
    (tmp_path / "single.npy").rename(tmp_path / "single.npz")
    for name, match in (("obj.npz", "v_template: not a plain array"), ("list.pkl", "expected an SMPL model"),
                        ("model.obj", "is .pkl or .npz"), ("single.npz", "got a single array"),
                        ("absent.pkl", "SMPL model file not found")):
        with pytest.raises(DataError, match=match) as info:
            load_body_model(tmp_path / name)
        assert name in str(info.value) and "\n" not in str(info.value)


def test_stand_ins_are_checked_and_nothing_else_gets_in(tmp_path):
    import scipy.sparse

    m = scipy.sparse.random(24, 50, density=0.2, format="csc", random_state=0)
    (tmp_path / "s.pkl").write_bytes(pickle.dumps({"r": m, "l": [m]}, protocol=4))
    back = safe_load(tmp_path / "s.pkl")
    np.testing.assert_array_equal(back["r"], m.toarray())
    assert isinstance(back["l"][0], np.ndarray)
    m.indices[0] = 99  # out of range: refused, not read
    (tmp_path / "bad.pkl").write_bytes(pickle.dumps(m, protocol=4))
    with pytest.raises(DataError, match="inconsistent compressed columns"):
        safe_load(tmp_path / "bad.pkl")
    big = scipy.sparse.csc_matrix((100_000, 100_000))
    (tmp_path / "big.pkl").write_bytes(pickle.dumps(big, protocol=4))
    with pytest.raises(DataError, match="too large"):
        safe_load(tmp_path / "big.pkl")
    with fake_chumpy() as Ch:
        empty = Ch(np.zeros(3))
        empty.x = "not an array"
        (tmp_path / "ch.pkl").write_bytes(pickle.dumps({"v": empty}, protocol=2))
    with pytest.raises(DataError, match="no plain array"):
        safe_load(tmp_path / "ch.pkl")
    (tmp_path / "lil.pkl").write_bytes(pickle.dumps(scipy.sparse.lil_matrix((2, 2)), protocol=4))
    with pytest.raises(DataError, match="refused to load"):
        safe_load(tmp_path / "lil.pkl")


def test_the_recipe_option_is_relative_to_the_recipe_folder(tmp_path):
    config = SmplFormatConfig(model="models/SMPL_NEUTRAL.pkl")
    assert SmplFormatConfig.model_fields["model"].json_schema_extra == {"path": True}
    assert resolve_paths(config, str(tmp_path)).model == str(tmp_path / "models" / "SMPL_NEUTRAL.pkl")
    assert get_registry().create("motion-format", "smpl", {"model": "m.npz"}).model_path() == "m.npz"


def test_writing_puts_the_pelvis_where_the_motion_has_it(tmp_path, monkeypatch):
    from dance_core.motion.motion import Motion
    from dance_core.motion.skeleton import Skeleton
    from dance_core.motion.skeletons import SMPL_NAMES

    monkeypatch.delenv(ENV_MODEL, raising=False)
    rng = np.random.default_rng(0)
    other = Skeleton(list(SMPL_NAMES), list(SMPL_PARENTS), rng.normal(scale=0.2, size=(24, 3)), name="other-body")
    rot = Rotation.from_rotvec(rng.normal(scale=0.3, size=(10 * 24, 3))).as_quat().reshape(10, 24, 4)
    motion = Motion(other, 60.0, rng.normal(size=(10, 3)) + [0, 1.0, 0], rot)
    with pytest.raises(DataError, match="out.pkl: AIST\\+\\+ SMPL parameters need an SMPL body model"):
        SmplFormat().write_motion(motion, tmp_path / "out.pkl")  # smpl_trans is relative to SMPL's pelvis
    model = write_npz(tmp_path / "m.npz", synthetic_model())
    SmplFormat(model=model).write_motion(motion, tmp_path / "out.pkl")
    back = SmplFormat(model=model).read_motion(tmp_path / "out.pkl")
    np.testing.assert_allclose(back.root, motion.root, atol=1e-5)
