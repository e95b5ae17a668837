import json
import os
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.data.files import read_motion_file as read_motion
from dance_core.errors import DataError
from dance_core.formats.joints import JointsFormat
from dance_core.formats.keypoints import KeypointsFormat
from dance_core.formats.smpl import SmplFormat
from dance_core.formats.unpickle import safe_load
from dance_core.motion.skeletons import BODY25_ORDER
from dance_core.protocols import MotionData
from dance_core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
from smpl_model_helpers import smpl_model  # noqa: E402, F401 - fixture: a synthetic SMPL model in DANCE_SMPL_MODEL

SMPL_SAMPLE = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures" / "smpl" / "smpl_sample.pkl"


@pytest.mark.usefixtures("smpl_model")
def test_reads_the_aist_sample_on_the_models_skeleton():
    data = read_motion(SMPL_SAMPLE, get_registry())
    motion = data.skeleton_motion
    assert data.values.shape == (127, 75) and motion.fps == 60.0 and len(motion.skeleton) == 24
    raw = safe_load(SMPL_SAMPLE)  # the fixture's raw arrays, through the restricted unpickler
    np.testing.assert_allclose(data.values[:, :72], raw["smpl_poses"], atol=1e-5)
    pos = motion.positions()
    np.testing.assert_allclose(pos[:, 0], motion.skeleton.offsets[0] + raw["smpl_trans"], atol=1e-6)
    bones = np.linalg.norm(pos[:, 1:] - pos[:, motion.skeleton.parents[1:]], axis=-1)
    lengths = np.linalg.norm(motion.skeleton.offsets[1:], axis=-1)
    np.testing.assert_allclose(bones, np.broadcast_to(lengths, bones.shape))


@pytest.mark.usefixtures("smpl_model")
def test_smpl_write_read_round_trip_with_scaling(tmp_path):
    fmt = SmplFormat()
    motion = fmt.read_motion(SMPL_SAMPLE)
    motion.meta["smpl_scaling"] = 93.0  # AIST++ stores centimetre-like translation with a scale
    fmt.write_motion(motion, tmp_path / "m.pkl")
    raw = safe_load(tmp_path / "m.pkl")
    np.testing.assert_allclose(raw["smpl_trans"], (motion.root - motion.skeleton.offsets[0]) * 93.0, rtol=1e-5)
    back = fmt.read_motion(tmp_path / "m.pkl")
    np.testing.assert_allclose(back.positions(), motion.positions(), atol=1e-5)


class Evil:
    def __reduce__(self):
        return (os.system, ("echo pwned",))


@pytest.mark.usefixtures("smpl_model")
@pytest.mark.parametrize("payload", [Evil(), {"smpl_poses": Evil()}, {"x": Path("/etc")}])
def test_the_restricted_unpickler_refuses_anything_but_containers_and_arrays(tmp_path, payload):
    path = tmp_path / "evil.pkl"
    path.write_bytes(pickle.dumps(payload))
    with pytest.raises(DataError, match="refused to load") as info:
        SmplFormat().read(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("protocol", [2, 4, 5])
def test_the_restricted_unpickler_admits_arrays_in_every_protocol(tmp_path, protocol):
    data = {"a": np.arange(6.0).reshape(2, 3), "s": np.float64(1.5), "l": [1, (2, "x")], "b": b"\x00\x01"}
    (tmp_path / "ok.pkl").write_bytes(pickle.dumps(data, protocol=protocol))
    back = safe_load(tmp_path / "ok.pkl")
    np.testing.assert_array_equal(back["a"], data["a"])
    assert back["s"] == 1.5 and back["l"] == [1, (2, "x")] and back["b"] == b"\x00\x01"


@pytest.mark.usefixtures("smpl_model")
@pytest.mark.parametrize("data, match", [
    ({"smpl_trans": np.zeros((3, 3))}, "smpl_poses: missing"),
    ({"smpl_poses": np.zeros((3, 70)), "smpl_trans": np.zeros((3, 3))}, r"smpl_poses: expected finite \(frames, 72\)"),
    ({"smpl_poses": np.zeros((3, 72)), "smpl_trans": np.zeros((4, 3))}, "3 frames, smpl_trans 4"),
    ([1, 2], "expected a dict"),
])
def test_bad_smpl_files_name_the_field(tmp_path, data, match):
    path = tmp_path / "bad.pkl"
    path.write_bytes(pickle.dumps(data))
    with pytest.raises(DataError, match=match):
        SmplFormat().read(path)


def test_humanml_joint_arrays_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    arr = rng.normal(size=(30, 22, 3)).astype(np.float32)
    np.save(tmp_path / "000001.npy", arr)
    data = read_motion(tmp_path / "000001.npy", get_registry())
    assert data.values.shape == (30, 66) and data.fps == 20.0 and data.skeleton_motion.skeleton.name == "smpl22"
    JointsFormat().write(data, tmp_path / "back.npy")
    np.testing.assert_allclose(np.load(tmp_path / "back.npy"), arr, atol=1e-6)
    np.save(tmp_path / "bad.npy", arr[:, :21])
    with pytest.raises(DataError, match=r"\(frames, 22, 3\)"):
        JointsFormat().read(tmp_path / "bad.npy")


def test_2d_keypoints_in_openpose_order_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 500, size=(12, 25, 2))
    (tmp_path / "k.json").write_text(json.dumps({"fps": 15, "keypoints": xy.tolist()}))
    m = KeypointsFormat(scale=0.01).read_motion(tmp_path / "k.json")
    assert m.fps == 15 and m.skeleton.name == "body25"
    neck = m.skeleton.index("Neck")
    np.testing.assert_allclose(m.positions()[:, neck, :2], xy[:, BODY25_ORDER.index("Neck")] * [0.01, -0.01])
    KeypointsFormat(scale=0.01).write(MotionData(np.zeros((12, 1)), 15, skeleton_motion=m), tmp_path / "o.json")
    np.testing.assert_allclose(json.loads((tmp_path / "o.json").read_text())["keypoints"], xy, atol=1e-4)
    dr = {"dance_array": xy.reshape(12, 50).tolist()}  # DanceRevolution's layout
    (tmp_path / "dr.json").write_text(json.dumps(dr))
    np.testing.assert_allclose(KeypointsFormat(scale=0.01).read_motion(tmp_path / "dr.json").positions(), m.positions())
    (tmp_path / "bad.json").write_text(json.dumps({"keypoints": [[1, 2]]}))
    with pytest.raises(DataError, match="keypoints: expected"):
        KeypointsFormat().read(tmp_path / "bad.json")
