"""BVH files other tools read right: absolute root position channels, an End Site under every leaf,
and the ``auto`` reading of files dance wrote before (root channels relative to the root OFFSET).

Checked against our own forward kinematics with an independent parser (bvhio) and with Blender's
own importer run headless (skipped without ``blender`` on PATH; ``make install`` installs Debian's
package when run as root).
"""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dance_core.errors import DataError
from dance_core.formats.bvh import BvhFormat, build, motion_to_bvh_text, written_end_sites
from dance_core.formats.configs import BvhFormatConfig
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import dance24, transflower21

sys.path.insert(0, str(Path(__file__).parent))
from blender_helpers import needs_blender, run_blender, y_up  # noqa: E402

CM = {"m": 0.01, "cm": 1.0}  # one centimetre in a skeleton's units


def _moved_root(skel: Skeleton, root: tuple[float, float, float]) -> Skeleton:
    """``skel`` with another root OFFSET (the rest of the body hangs from it as before)."""
    offsets = skel.offsets.copy()
    offsets[0] = root
    return replace(skel, offsets=offsets, end_sites=dict(skel.end_sites), name=f"{skel.name}-moved")


SKELETONS = {
    "dance24": dance24,  # metres, root OFFSET at the rest pelvis height (0, 0.98, 0)
    "transflower21": transflower21,  # centimetres, root OFFSET (0, 95, 0)
    "offset-xyz": lambda: _moved_root(dance24(), (0.3, 0.95, -0.2)),  # non-zero x and z too
}


def _dance(skel: Skeleton, frames: int = 30, seed: int = 0, lift: float = 0.0) -> Motion:
    """A smooth made-up dance that stands on the floor every frame (its lowest joint or End Site at
    height 0, or ``lift`` skeleton heights above it) and wanders on the ground."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None, None] / 30.0
    rotvec = rng.normal(0, 0.3, (len(skel), 3)) * np.sin(2 * np.pi * t + rng.uniform(0, 6.3, (len(skel), 3)))
    rot = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_quat().reshape(frames, len(skel), 4)
    h = skel.height()
    tt = t[:, 0, 0]
    root = skel.offsets[0] + np.stack([0.2 * h * np.sin(tt), 0 * tt, 0.3 * h * tt], axis=1)
    motion = Motion(skel, 30.0, root, rot)
    root[:, 1] -= motion.positions(end_sites=True)[..., 1].min(axis=1) - lift * h
    return Motion(skel, 30.0, root, rot)


def _old_style_text(motion: Motion) -> str:
    """BVH text the way dance wrote it before: root channels relative to the root OFFSET."""
    return motion_to_bvh_text(replace(motion, root=motion.root - motion.skeleton.offsets[0]))


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_root_channels_are_absolute_and_the_offset_is_the_rest_offset(tmp_path):
    motion = _dance(dance24())
    BvhFormat().write_motion(motion, tmp_path / "a.bvh")
    lines = (tmp_path / "a.bvh").read_text().splitlines()
    offset = [float(v) for v in lines[3].split()[1:]]
    assert lines[3].split()[0] == "OFFSET" and np.allclose(offset, motion.skeleton.offsets[0], atol=1e-6)
    first = [float(v) for v in lines[lines.index("MOTION") + 3].split()[:3]]
    np.testing.assert_allclose(first, motion.root[0], atol=1e-6)


def test_every_leaf_gets_an_end_site_and_the_skeleton_is_left_alone(tmp_path):
    skel = replace(dance24(), end_sites={})
    motion = _dance(skel)
    leaves = [j for j in range(len(skel)) if not skel.children(j)]
    ends = written_end_sites(skel)
    assert sorted(ends) == leaves and skel.end_sites == {}
    for j in leaves:  # half the parent->leaf bone, continuing it
        np.testing.assert_allclose(ends[j], 0.5 * skel.offsets[j])
    BvhFormat().write_motion(motion, tmp_path / "e.bvh")
    assert (tmp_path / "e.bvh").read_text().count("End Site") == len(leaves) and motion.skeleton.end_sites == {}
    back = BvhFormat().read_motion(tmp_path / "e.bvh").conformed(skel)
    assert sorted(back.skeleton.end_sites) == leaves  # the file's End Sites, read back as they were written
    for j in leaves:
        np.testing.assert_allclose(back.skeleton.end_sites[j], ends[j], atol=1e-6)
    np.testing.assert_allclose(back.positions(), motion.positions(), atol=1e-5)
    # a skeleton's own End Sites are written as they are
    assert {k: v.tolist() for k, v in written_end_sites(dance24()).items()} == \
        {k: v.tolist() for k, v in dance24().end_sites.items()}


def test_a_zero_length_leaf_bone_still_gets_a_real_end_site():
    skel = Skeleton(["root", "a", "b"], [-1, 0, 1], [[0, 1, 0], [0, -0.5, 0], [0, 0, 0]], units="m")
    ends = written_end_sites(skel)
    assert list(ends) == [2]
    np.testing.assert_allclose(ends[2], [0, -0.25, 0])  # continues the nearest non-zero bone above
    alone = written_end_sites(Skeleton(["root"], [-1], [[0, 0, 0]]))
    assert np.linalg.norm(alone[0]) > 0


@pytest.mark.parametrize("name", SKELETONS)
def test_an_independent_parser_finds_the_same_lowest_point(name, tmp_path):
    """bvhio reads root channels as absolute positions: the lowest joint or End Site per frame is
    our FK's (with the old relative writer it was off by the root OFFSET's height)."""
    bvhio = pytest.importorskip("bvhio")
    glm = pytest.importorskip("glm")
    skel = SKELETONS[name]()
    motion = _dance(skel, seed=1)
    BvhFormat().write_motion(motion, tmp_path / "b.bvh")
    bvh = bvhio.readAsBvh(str(tmp_path / "b.bvh"))
    # bvhio turns each joint's frame towards its bone: an End Site is local after undoing that turn
    ends = {j.Name: glm.inverse(j.getRotation()) * j.EndSite for j, _, _ in bvh.Root.layout() if not j.Children}
    root = bvhio.convertBvhToHierarchy(bvh.Root)
    layout = root.layout()
    order = [skel.index(j.Name) for j, _, _ in layout]
    ours = motion.positions(end_sites=True)
    for frame in range(motion.n_frames):
        root.loadPose(frame)
        joints = np.array([list(j.PositionWorld) for j, _, _ in layout])
        tips = np.array([list(j.pointToWorld(ends[j.Name])) for j, _, _ in layout if j.Name in ends])
        assert len(tips) == len(skel.end_sites)
        assert np.abs(joints - ours[frame, : len(skel)][order]).max() < CM[skel.units]
        lowest = min(joints[:, 1].min(), tips[:, 1].min())
        assert abs(lowest - ours[frame, :, 1].min()) < CM[skel.units] and abs(lowest) < CM[skel.units]


@pytest.mark.parametrize("name", SKELETONS)
@pytest.mark.parametrize("style", ["new", "old"])
def test_auto_reads_new_and_old_files(name, style, tmp_path):
    skel = SKELETONS[name]()
    motion = _dance(skel, frames=40, seed=2)
    path = tmp_path / f"{style}.bvh"
    if style == "new":
        BvhFormat().write_motion(motion, path)
    else:
        _write(path, _old_style_text(motion))
    tol = 1e-4 * skel.height()
    back = BvhFormat().read_motion(path).conformed(skel)
    np.testing.assert_allclose(back.positions(end_sites=True), motion.positions(end_sites=True), atol=tol)
    forced = BvhFormat(root="relative" if style == "old" else "absolute").read_motion(path).conformed(skel)
    np.testing.assert_allclose(forced.root, motion.root, atol=tol)
    wrong = BvhFormat(root="absolute" if style == "old" else "relative").read_motion(path).conformed(skel)
    shift = -skel.offsets[0] if style == "old" else skel.offsets[0]
    np.testing.assert_allclose(wrong.root, motion.root + shift, atol=tol)


def test_auto_keeps_absolute_when_neither_or_both_readings_stand(tmp_path):
    skel = dance24()
    jump = _dance(skel, seed=3, lift=0.3)  # in the air whichever way it is read: absolute
    BvhFormat().write_motion(jump, tmp_path / "jump.bvh")
    np.testing.assert_allclose(BvhFormat().read_motion(tmp_path / "jump.bvh").conformed(skel).root, jump.root,
                               atol=1e-5)
    flat = _moved_root(skel, (0.3, 0.0, -0.2))  # a horizontal OFFSET: both stand, so absolute...
    walk = _dance(flat, seed=4)
    old = _write(tmp_path / "flat-old.bvh", _old_style_text(walk))
    np.testing.assert_allclose(BvhFormat().read_motion(old).conformed(flat).root, walk.root - flat.offsets[0],
                               atol=1e-5)
    # ... and an old file of it needs root: relative
    np.testing.assert_allclose(BvhFormat(root="relative").read_motion(old).conformed(flat).root, walk.root,
                               atol=1e-5)


def test_auto_reads_old_z_up_files(tmp_path):
    from dance_core.formats.bvh import Z_TO_Y_UP, reoriented
    from dance_core.motion.rotations import quat_conj

    skel = transflower21()
    motion = _dance(skel, seed=5)
    BvhFormat(up="z").write_motion(motion, tmp_path / "new.bvh")
    _write(tmp_path / "old.bvh", _old_style_text(reoriented(motion, quat_conj(Z_TO_Y_UP))))
    for name in ("new.bvh", "old.bvh"):
        back = BvhFormat(up="z").read_motion(tmp_path / name).conformed(skel)
        np.testing.assert_allclose(back.positions(), motion.positions(), atol=1e-3)


def test_the_root_option_through_the_config():
    assert BvhFormatConfig().root == "auto" and build(BvhFormatConfig()).root == "auto"
    assert build(BvhFormatConfig(root="relative")).root == "relative"
    with pytest.raises(ValueError):
        BvhFormatConfig(root="sideways")
    with pytest.raises(DataError, match="root must be one of"):
        BvhFormat(root="sideways")


@needs_blender
@pytest.mark.parametrize("name", ["dance24", "offset-xyz", "dance24-no-end-sites"])
def test_blender_imports_our_dancer_onto_the_floor(name, tmp_path):
    """Blender's own BVH importer (headless, a 30-frame dance) puts every bone where our FK puts the
    joints, and the lowest bone head or tail per frame at our FK's lowest point, within 1 cm, with
    the same frame count, and warns of no zero-length bone. With the old writer (root channels
    relative to the root OFFSET) this failed: Blender reads them as absolute, so the dancer floated
    the root OFFSET's height (0.98 m for dance24) too low, and leaves without an End Site were
    zero-length bones."""
    skel = replace(dance24(), end_sites={}) if name == "dance24-no-end-sites" else SKELETONS[name]()
    motion = _dance(skel, frames=30, seed=6)
    BvhFormat().write_motion(motion, tmp_path / "d.bvh")
    data, log = run_blender(tmp_path / "d.bvh", tmp_path / "d.json")
    assert data["frames"] == motion.n_frames and "zero length" not in log
    heads, tails = y_up(data["heads"]), y_up(data["tails"])
    ours = motion.positions(end_sites=True)
    order = [skel.index(n) for n in data["bones"]]
    assert np.abs(heads - ours[:, order]).max() < CM[skel.units]
    lowest = np.minimum(heads[..., 1].min(axis=1), tails[..., 1].min(axis=1))
    if not skel.end_sites:  # the file's synthesized End Sites: our reading of the file has them
        ours = BvhFormat().read_motion(tmp_path / "d.bvh").positions(end_sites=True)
    # every tail is a joint, an End Site, or a mean of joints
    assert np.abs(lowest - ours[..., 1].min(axis=1)).max() < CM[skel.units]
