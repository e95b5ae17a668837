"""``dance compose``'s edits on a tiny core-dance model (autoregressive: a window of past motion feeds each
step): keyframes hit, --regenerate keeping every other frame bit for bit, kept legs, facing, loops, recipe
fields, and bad input as one line before any work with nothing written."""

import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.formats.bvh import BvhFormat
from dance_core.motion.keyframes import keyframe_of, pose_error
from dance_core.motion.loop import wrap_jump
from dance_core.motion.parts import part_joints
from dance_core.motion.root import heading
from dance_core.motion.skeleton import Skeleton

sys.path.insert(0, str(Path(__file__).parent))
from compose_helpers import TINY, click_song, tiny_checkpoint  # noqa: E402
from test_bvh_dcc import _dance  # noqa: E402
from test_motion_edits import jerk, steps  # noqa: E402


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A tiny core-dance checkpoint, an 8 s click-track song and a plain dance composed for it."""
    root = tmp_path_factory.mktemp("edits")
    checkpoint = tiny_checkpoint(root)
    song = click_song(root / "song.wav", 8.0)
    assert compose_cli((checkpoint, song, None), root / "plain") == 0
    return checkpoint, song, root / "plain" / "song.bvh"


def compose_cli(model, out, *extra):
    checkpoint, song, _ = model
    return main(["compose", "core-dance", *(f"--set={s}" for s in TINY), "--checkpoint", checkpoint,
                 "--music", song, "-o", str(out), "--quiet", "--format", "bvh", *extra])


def read(path):
    from dance_core.motion.skeletons import dance24

    return BvhFormat().read_motion(path).conformed(dance24())


def test_keyframe_is_hit_and_moved_into_smoothly(model, tmp_path):
    pose = tmp_path / "pose.bvh"
    BvhFormat().write_motion(_dance(read(model[2]).skeleton, frames=20, seed=11), pose)
    assert compose_cli(model, tmp_path / "out", "--keyframe", f"4.0={pose}:10") == 0
    out, plain = read(tmp_path / "out" / "song.bvh"), read(model[2])
    key = keyframe_of(read(pose), 4.0, 10, "pose.bvh")
    assert pose_error(plain, key) > 0.05 and pose_error(out, key) < 0.02
    j = jerk(out)
    near = np.abs(np.arange(len(j)) + 1.5 - 4.0 * out.fps) <= out.fps
    assert j[near].mean() <= 1.5 * j[~near].mean()


def test_regenerate_keeps_every_other_frame_bit_for_bit(model, tmp_path):
    assert compose_cli(model, tmp_path / "out", "--from", str(model[2]), "--regenerate", "3-5", "--set=seed=7") == 0
    given, edited = read(model[2]), read(tmp_path / "out" / "song.bvh")
    outside = np.ones(given.n_frames, bool)
    outside[60:100] = False
    assert edited.n_frames == given.n_frames
    np.testing.assert_array_equal(edited.rotations[outside], given.rotations[outside])  # bit for bit
    np.testing.assert_array_equal(edited.root[outside], given.root[outside])
    # the file's frame lines too, byte for byte (the writer never prints a negative zero)
    text = [p.read_bytes().split(b"\n") for p in (model[2], tmp_path / "out" / "song.bvh")]
    first = text[0].index(b"MOTION") + 3
    assert text[1][:first] == text[0][:first]  # the hierarchy and the header too
    kept = np.flatnonzero(outside) + first
    assert [text[1][i] for i in kept] == [text[0][i] for i in kept]
    assert all(text[1][i] != text[0][i] for i in range(first + 62, first + 98))  # the span's own lines differ
    assert (np.abs(edited.rotations[60:100] - given.rotations[60:100]).max(axis=(1, 2)) > 1e-3).sum() >= 35
    s = steps(edited)
    assert s[99] <= 2.0 * np.percentile(steps(given), 95)  # led into the kept frames


def test_keep_legs_face_camera_and_loop(model, tmp_path):
    walk = tmp_path / "walk.bvh"
    BvhFormat().write_motion(_dance(read(model[2]).skeleton, frames=30, seed=4).resample(20.0), walk)
    assert compose_cli(model, tmp_path / "out", "--keep", f"legs={walk}", "--face", "camera", "--loop",
                       "--set=compose.ground=false", "--set=compose.beat_align=false") == 0
    out, source = read(tmp_path / "out" / "song.bvh"), read(walk)
    legs = part_joints(out, "legs")
    assert np.abs(out.rotations[:15, legs] - source.rotations[:15, legs]).max() < 1e-3 or np.abs(
        out.rotations[:15, legs] + source.rotations[:15, legs]).max() < 1e-3  # BVH text rounding
    assert np.degrees(np.abs(heading(out.rotations[:, 0]))).max() <= 61.0
    assert wrap_jump(out) <= 1.5 * np.percentile(steps(out), 90)


def test_recipe_fields_say_the_same(model, tmp_path):
    pose = tmp_path / "pose.bvh"
    BvhFormat().write_motion(_dance(read(model[2]).skeleton, frames=5, seed=2), pose)
    recipe = tmp_path / "r.yaml"
    recipe.write_text("extends: core-dance\ncompose:\n  keyframes: ['2.5=pose.bvh:3']\n  face: camera\n")
    checkpoint, song, _ = model
    assert main(["compose", str(recipe), *(f"--set={s}" for s in TINY), "--checkpoint", checkpoint, "--music",
                 song, "-o", str(tmp_path / "out"), "--quiet", "--format", "bvh"]) == 0
    out = read(tmp_path / "out" / "song.bvh")
    assert pose_error(out, keyframe_of(read(pose), 2.5, 3)) < 0.02


def test_bad_edits_are_one_line_before_any_work(model, tmp_path, capsys):
    pose, odd = tmp_path / "pose.bvh", tmp_path / "odd.bvh"
    BvhFormat().write_motion(_dance(read(model[2]).skeleton, frames=5), pose)
    skel = Skeleton(["a", "b", "c"], [-1, 0, 1], np.array([[0, 1, 0], [0, 0.5, 0], [0, 0.5, 0]], float), name="odd")
    BvhFormat().write_motion(_dance(skel, frames=3), odd)
    cases = [
        (["--keyframe", f"30={pose}"], "past the dance"),
        (["--keyframe", f"2={pose}:9"], "frame 9 is past"),
        (["--keyframe", f"2={tmp_path / 'none.bvh'}"], "not found"),
        (["--keyframe", f"2={odd}"], "cannot be mapped"),
        (["--keyframe", "two=pose.bvh"], "SECONDS=POSE_FILE"),
        (["--keep", f"tail={pose}"], "unknown body part 'tail'"),
        (["--from", str(model[2]), "--regenerate", "1-3", "--regenerate", "2-4"], "overlap"),
        (["--from", str(model[2]), "--regenerate", "5-30"], "past the dance"),
        (["--regenerate", "1-2"], "needs the dance to edit"),
        (["--from", str(model[2]), "--regenerate", "1-2", "--loop"], "in a run of their own"),
    ]
    for extra, message in cases:
        assert compose_cli(model, tmp_path / "out", *extra) != 0, extra
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, (extra, err)
        assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_family_that_rewrites_its_motion_cannot_regenerate():
    from types import SimpleNamespace

    from dance_core.compose.edits import Edits, limits
    from dance_core.errors import RecipeError

    head = type("TokenHead", (), {"rewrites_motion": True})()
    with pytest.raises(RecipeError, match="TokenHead head decodes the whole dance"):
        limits(SimpleNamespace(head=head), Edits(source=_dance(Skeleton(["a"], [-1], np.zeros((1, 3))), 2)),
               "--from")
