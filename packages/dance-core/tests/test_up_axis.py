"""``dance convert --up z``: BVH and NPZ written Z up for Z-up tools (Blender's, Unreal's, 3ds Max's world),
read back to the same dance; glb stays Y up (glTF 2.0 says so) and asking for it Z up is one line."""

import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.delivery import written_up, z_up
from dance_core.formats.bvh import BvhFormat
from dance_core.formats.glb import GlbFormat
from dance_core.formats.npz import NpzFormat
from dance_core.motion.skeletons import dance24

sys.path.insert(0, str(Path(__file__).parent))
from test_bvh_dcc import _dance  # noqa: E402


@pytest.fixture
def dance_file(tmp_path):
    motion = _dance(dance24(), frames=40, seed=3)
    BvhFormat().write_motion(motion, tmp_path / "dance.bvh")
    return tmp_path / "dance.bvh", BvhFormat().read_motion(tmp_path / "dance.bvh")


def test_z_up_bvh_round_trip(dance_file, tmp_path):
    path, ours = dance_file
    assert main(["convert", str(path), "-o", str(tmp_path / "z.bvh"), "--up", "z"]) == 0
    raw = BvhFormat().read_motion(tmp_path / "z.bvh").positions(end_sites=True)  # the file as it is: Z up
    y = ours.positions(end_sites=True)
    np.testing.assert_allclose(raw[..., 2], y[..., 1], atol=1e-5)  # height is the file's z
    np.testing.assert_allclose(raw[..., 1], -y[..., 2], atol=1e-5)  # glTF's front (+Z) is -Y, as in Blender
    np.testing.assert_allclose(raw[..., 0], y[..., 0], atol=1e-5)
    assert abs(raw[..., 2].min(axis=1)).max() < 1e-4  # the feet on the floor z = 0 every frame
    back = BvhFormat(up="z").read_motion(tmp_path / "z.bvh")  # read as a Z-up file: the dance again
    np.testing.assert_allclose(back.positions(end_sites=True), y, atol=1e-5)
    assert np.abs(back.skeleton.rest_positions() - ours.skeleton.rest_positions()).max() < 1e-5  # stands up again


def test_z_up_npz_holds_turned_joint_positions(dance_file, tmp_path):
    path, ours = dance_file
    assert main(["convert", str(path), "-o", str(tmp_path / "z.npz"), "--up", "z"]) == 0
    data = NpzFormat().read(tmp_path / "z.npz")
    points = data.values.reshape(ours.n_frames, len(ours.skeleton), 3)
    y = ours.positions()
    np.testing.assert_allclose(points, np.stack([y[..., 0], -y[..., 2], y[..., 1]], axis=-1), atol=1e-5)
    assert data.channels == [f"{name}.{axis}" for name in ours.skeleton.names for axis in "xyz"]


def test_glb_stays_y_up_and_asking_z_is_one_line(dance_file, tmp_path, capsys):
    path, ours = dance_file
    assert main(["convert", str(path), "-o", str(tmp_path / "z.glb"), "--up", "z"]) != 0
    err = capsys.readouterr().err.strip()
    assert "--up z" in err and "glTF" in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "z.glb").exists()
    assert main(["convert", str(path), "-o", str(tmp_path / "y.glb"), "--up", "y"]) == 0
    glb, _ = GlbFormat().read_motion(tmp_path / "y.glb")
    np.testing.assert_allclose(glb.positions(), ours.positions(), atol=1e-5)


def test_written_up_turns_only_formats_that_can_be_z_up(dance_file):
    from dance_core.delivery import motion_data

    _, ours = dance_file
    data = motion_data(ours)
    assert written_up(data, "glb", "z") is data and written_up(data, "html", "z") is data
    assert written_up(data, "bvh", "y") is data
    turned = written_up(data, "bvh", "z").skeleton_motion
    assert turned.skeleton.up == "z" and z_up(turned) is turned  # never turned twice
    np.testing.assert_allclose(turned.positions()[..., 2], ours.positions()[..., 1], atol=1e-9)


def test_a_z_up_format_option_does_not_turn_a_z_up_dance_again(dance_file, tmp_path):
    _, ours = dance_file
    BvhFormat(up="z").write_motion(z_up(ours), tmp_path / "a.bvh")
    BvhFormat(up="z").write_motion(ours, tmp_path / "b.bvh")
    assert (tmp_path / "a.bvh").read_bytes() == (tmp_path / "b.bvh").read_bytes()
