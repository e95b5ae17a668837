from pathlib import Path

import numpy as np
import pytest

from dance_core.data.files import read_motion_file as read_motion
from dance_core.errors import DataError
from dance_core.formats.bvh import BvhFormat
from dance_core.registry import get_registry

FIXTURES = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures"
CMU = FIXTURES / "bvh" / "cmu_01_01.bvh"


@pytest.fixture(scope="module")
def cmu():
    return BvhFormat().read_motion(CMU)


def test_reads_the_real_mocap_fixture(cmu):
    assert cmu.n_frames == 2752 and cmu.fps == 120.0 and len(cmu.skeleton) == 31
    assert cmu.skeleton.names[:3] == ["Hips", "LHipJoint", "LeftUpLeg"] and len(cmu.skeleton.end_sites) == 7
    assert cmu.skeleton.channels[0] == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
    np.testing.assert_allclose(cmu.root[0], [9.3722, 17.8693, -17.3198])
    data = read_motion(CMU, get_registry())  # through the registry, by suffix
    assert data.values.shape == (2752, 6 + 30 * 3) and data.channels[3] == "Hips.Zrotation"


def test_write_then_read_gives_the_same_world_positions(cmu, tmp_path):
    BvhFormat().write_motion(cmu, tmp_path / "x.bvh")
    back = BvhFormat().read_motion(tmp_path / "x.bvh")
    err = np.abs(back.positions(end_sites=True) - cmu.positions(end_sites=True)).max()
    assert err <= 1e-4 * cmu.skeleton.height()
    assert back.skeleton.names == cmu.skeleton.names and back.skeleton.channels == cmu.skeleton.channels


def test_an_independent_parser_reads_our_file_to_the_same_positions(cmu, tmp_path):
    bvhio = pytest.importorskip("bvhio")
    short = cmu.crop(0, 400)
    BvhFormat().write_motion(short, tmp_path / "y.bvh")
    root = bvhio.readAsHierarchy(str(tmp_path / "y.bvh"))
    layout = root.layout()
    order = [short.skeleton.index(j.Name) for j, _, _ in layout]
    ours = short.positions()
    for frame in (0, 137, 399):
        root.loadPose(frame)
        theirs = np.array([list(j.PositionWorld) for j, _, _ in layout])
        assert np.abs(theirs - ours[frame, order]).max() <= 1e-4 * cmu.skeleton.height()


def test_any_channel_order_and_a_unit_scale(cmu, tmp_path):
    short = cmu.crop(100, 160)
    skel = short.skeleton
    skel_orders = ["YXZ", "XZY", "ZXY"]
    short.skeleton.channels = [tuple(f"{a}rotation" for a in skel_orders[j % 3]) if j else skel.channels[0]
                               for j in range(len(skel))]
    BvhFormat(scale=0.01).write_motion(short, tmp_path / "o.bvh")  # metres in memory -> file x100
    text = (tmp_path / "o.bvh").read_text()
    assert "CHANNELS 3 YXZ".replace("YXZ", "Yrotation Xrotation Zrotation") in text
    metres = BvhFormat(scale=0.01).read_motion(tmp_path / "o.bvh")
    np.testing.assert_allclose(metres.positions(), short.positions(), atol=1e-6 * skel.height())
    file_units = BvhFormat().read_motion(tmp_path / "o.bvh")
    np.testing.assert_allclose(file_units.positions(), 100 * short.positions(), atol=1e-4 * skel.height() * 100)


def test_written_euler_angles_never_jump(tmp_path):
    from scipy.spatial.transform import Rotation

    from dance_core.motion.motion import Motion
    from dance_core.motion.skeletons import dance24

    skel = dance24()
    t = np.linspace(0, 1, 200)
    spin = Rotation.from_rotvec(np.outer(6 * np.pi * t, [0, 1, 0.2])).as_quat()
    rot = np.zeros((200, 24, 4))
    rot[..., 3] = 1
    rot[:, 0] = spin
    BvhFormat().write_motion(Motion(skel, 30.0, np.zeros((200, 3)), rot), tmp_path / "s.bvh")
    frames = BvhFormat().read(tmp_path / "s.bvh").values
    assert np.abs(np.diff(frames[:, 3:6], axis=0)).max() < 20


def test_no_number_is_written_as_a_negative_zero(tmp_path):
    """-0.0 and tiny negative numbers print as 0.000000 (a pose read and written again may turn a -0.0 into
    +0.0; the text stays the same), while a small negative number that does not round to zero keeps its sign."""
    import re

    from dance_core.motion.motion import Motion
    from dance_core.motion.skeletons import dance24

    skel = dance24()
    skel.offsets[1, 0] = -0.0
    skel.offsets[2, 2] = -3e-8
    rot = np.zeros((3, 24, 4))
    rot[..., 3] = 1
    root = np.array([[-0.0, 0.9, -4e-7], [-1e-12, 0.9, 0.0], [-2e-6, 0.9, 0.0]])
    BvhFormat().write_motion(Motion(skel, 30.0, root, rot), tmp_path / "z.bvh")
    text = (tmp_path / "z.bvh").read_text()
    assert not re.search(r"-0\.0+(?![0-9])", text)
    frames = text.splitlines()[text.splitlines().index("MOTION") + 3:]
    assert [line.split()[:3] for line in frames] == [["0.000000", "0.900000", "0.000000"],
                                                     ["0.000000", "0.900000", "0.000000"],
                                                     ["-0.000002", "0.900000", "0.000000"]]


@pytest.mark.parametrize("text, match", [
    ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Wrotation\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n",
     "unknown channel"),
    ("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n", "MOTION"),
    ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}\nMOTION\nFrames: 2\n"
     "Frame Time: 0.1\n1 2 3\n", "2 frames of 3 channels declared, found 1"),
    ("not a bvh", "no MOTION"),
])
def test_broken_files_are_one_line_errors(tmp_path, text, match):
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    with pytest.raises(DataError, match=match) as info:
        BvhFormat().read(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_writing_features_without_a_skeleton_is_refused(tmp_path):
    from dance_core.protocols import MotionData

    with pytest.raises(DataError, match="skeletal motion"):
        BvhFormat().write(MotionData(np.zeros((3, 4), np.float32), 20.0), tmp_path / "x.bvh")
    with pytest.raises(DataError, match="not found"):
        BvhFormat().read(tmp_path / "missing.bvh")


def test_real_mocap_through_transflowers_representation_and_resampling(cmu):
    from dance_core.motion.representation import RotationRepresentation
    from dance_core.motion.root import root_to_deltas
    from dance_core.motion.rotations import quat_conj, quat_rotate, yaw_quat

    clip = cmu.crop(0, 1200)  # 10 s at 120 fps
    rep = RotationRepresentation("expmap", "deltas")
    values = rep.encode(clip)
    assert values.shape == (1200, 4 + 31 * 3)
    _, _, start = root_to_deltas(clip.root, clip.rotations[:, 0])
    ref = quat_rotate(quat_conj(yaw_quat(start.yaw)), clip.positions() - [start.x, 0.0, start.z])
    err = np.abs(rep.decode(values, clip.skeleton, clip.fps).positions() - ref).max()
    assert err <= 1e-4 * cmu.skeleton.height()  # float32 features, integrated over 1200 frames
    slow = clip.resample(20.0)  # Transflower's rate, low-pass filtered first
    assert slow.n_frames == 200
    diff = np.abs(slow.positions() - clip.positions()[::6])
    assert np.percentile(diff, 99) < 0.01 * cmu.skeleton.height() and diff.max() < 0.06 * cmu.skeleton.height()


def test_z_up_files_are_turned_to_y_up_and_back(cmu, tmp_path):
    short = cmu.crop(0, 50)
    BvhFormat(up="z").write_motion(short, tmp_path / "z.bvh")
    raw = BvhFormat().read_motion(tmp_path / "z.bvh").positions()  # read as if Y up: the file is Z up
    ours = short.positions()
    np.testing.assert_allclose(raw[..., 2], ours[..., 1], atol=1e-4 * cmu.skeleton.height())  # up is file z
    np.testing.assert_allclose(raw[..., 1], -ours[..., 2], atol=1e-4 * cmu.skeleton.height())
    back = BvhFormat(up="z").read_motion(tmp_path / "z.bvh")
    np.testing.assert_allclose(back.positions(), ours, atol=1e-4 * cmu.skeleton.height())
    assert np.abs(back.skeleton.rest_positions() - cmu.skeleton.rest_positions()).max() < 1e-9  # stands up again
