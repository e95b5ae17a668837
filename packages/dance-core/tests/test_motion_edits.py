"""The motion edits behind ``dance compose``'s --loop, --face, --max-turn, --keyframe, --keep and --regenerate,
on made-up dances: the properties each promises, measured."""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.motion.facing import face
from dance_core.motion.keyframes import Keyframe, hit, keyframe_of, pose_error
from dance_core.motion.loop import looped, wrap_jump
from dance_core.motion.parts import keep_part, part_joints
from dance_core.motion.root import heading
from dance_core.motion.rotations import quat_mul, yaw_quat
from dance_core.motion.skeletons import dance24
from dance_core.motion.splice import placed, splice

sys.path.insert(0, str(Path(__file__).parent))
from test_bvh_dcc import _dance  # noqa: E402


def steps(motion):
    """Per frame, the largest joint displacement from the frame before."""
    return np.linalg.norm(np.diff(motion.positions(), axis=0), axis=-1).max(axis=1)


def jerk(motion):
    """Per frame, the mean joint jerk magnitude (third difference of positions)."""
    return np.linalg.norm(np.diff(motion.positions(), n=3, axis=0), axis=-1).mean(axis=1) * motion.fps**3


def spinning(frames=300, turns=3.0, seed=0):
    """A dance that turns ``turns`` times over its length, as the default model's do."""
    m = _dance(dance24(), frames=frames, seed=seed)
    yaw = np.linspace(0, 2 * np.pi * turns, frames)
    rot = m.rotations.copy()
    rot[:, 0] = quat_mul(yaw_quat(yaw), rot[:, 0])
    return replace(m, rotations=rot)


def test_loop_wrap_around_is_an_ordinary_step():
    m = spinning(240, 1.3, seed=2)
    assert wrap_jump(m) > 5 * np.median(steps(m))  # as made: the end is far from the start
    out = looped(m)
    assert wrap_jump(out) <= 1.5 * np.percentile(steps(out), 90)
    np.testing.assert_array_equal(out.rotations[: 240 - 30], m.rotations[: 240 - 30])  # only the last second bent
    assert np.abs(heading(out.rotations[-1, 0]) - heading(out.rotations[0, 0])) < 0.2


def test_face_camera_keeps_the_heading_near_plus_z_and_turns_stay_quick():
    m = spinning(300, 3.0)
    out = face(m, "camera")
    yaw = heading(out.rotations[:, 0])
    assert np.degrees(np.abs(yaw)).max() <= 61.0  # about +Z; the dance turned round three times
    assert np.degrees(np.abs(heading(m.rotations[:, 0]))).max() > 170
    # the body's own pose is untouched, only its heading: joint rotations below the root are the same
    np.testing.assert_array_equal(out.rotations[:, 1:], m.rotations[:, 1:])
    assert out.root[:, 1] == pytest.approx(m.root[:, 1])  # heights kept; the path turned with the body


def test_max_turn_limits_turning_speed():
    m = spinning(300, 3.0)
    out = face(m, "free", max_turn=90.0)
    rate = np.degrees(np.abs(np.diff(np.unwrap(heading(out.rotations[:, 0]))))) * m.fps
    assert rate.max() <= 90.0 + 1e-6
    assert np.degrees(np.abs(np.diff(np.unwrap(heading(m.rotations[:, 0]))))).max() * m.fps > 100


def test_keyframe_is_hit_within_2cm_and_moved_into_smoothly():
    m = _dance(dance24(), frames=240, seed=3)
    pose = _dance(dance24(), frames=40, seed=9)
    key = keyframe_of(pose, 4.0, frame=30, where="pose.bvh")
    assert pose_error(m, key) > 0.1  # the dance is far from the pose before
    out = hit(m, [key])
    assert pose_error(out, key) < 0.02
    j = jerk(out)
    near = np.abs(np.arange(len(j)) + 1.5 - 4.0 * m.fps) <= m.fps
    assert j[near].mean() <= 1.5 * j[~near].mean()
    far = np.abs(np.arange(240) - 120) > 30
    np.testing.assert_array_equal(out.rotations[far], m.rotations[far])  # outside ±1 s: the dance as it was


def test_keyframes_past_the_dance_or_too_close_are_one_line():
    m = _dance(dance24(), frames=60)
    key = keyframe_of(m, 0.0, 0, "a")
    with pytest.raises(DataError, match="past the dance"):
        hit(m, [replace(key, time=5.0)])
    with pytest.raises(DataError, match="keyframes need"):
        hit(m, [key, replace(key, time=0.1, where="b")])
    with pytest.raises(DataError, match="frame 99 is past"):
        keyframe_of(m, 1.0, 99, "pose.bvh")
    with pytest.raises(DataError, match="joints"):
        hit(m, [Keyframe(1.0, key.rotations[:5], 1.0, "pose.bvh")])


def test_keep_legs_takes_their_rotations_and_the_root_path():
    dance, walk = _dance(dance24(), frames=90, seed=1), _dance(dance24(), frames=40, seed=7)
    out = keep_part(dance, walk, "legs", "walk.bvh")
    legs = part_joints(dance, "legs")
    assert len(legs) == 8
    np.testing.assert_array_equal(out.rotations[:40, legs], walk.rotations[:, legs])
    np.testing.assert_array_equal(out.rotations[40:80, legs], walk.rotations[:, legs])  # repeated
    others = [j for j in range(24) if j not in legs]
    np.testing.assert_array_equal(out.rotations[:, others], dance.rotations[:, others])
    np.testing.assert_allclose(out.root[:40, 1], walk.root[:, 1])
    with pytest.raises(DataError, match="unknown body part 'tail'"):
        keep_part(dance, walk, "tail", "walk.bvh")


def test_splice_keeps_everything_outside_the_spans_bit_for_bit():
    dance, take = _dance(dance24(), frames=120, seed=1), _dance(dance24(), frames=120, seed=5)
    take = replace(take, root=take.root + np.array([3.0, 0.0, -2.0]))  # somewhere else on the floor
    out = splice(dance, take, [(30, 60), (90, 100)])
    outside = np.ones(120, bool)
    outside[30:60] = outside[90:100] = False
    np.testing.assert_array_equal(out.rotations[outside], dance.rotations[outside])
    np.testing.assert_array_equal(out.root[outside], dance.root[outside])
    assert not np.allclose(out.rotations[40], dance.rotations[40])
    # out of each span into the kept frames: no jump bigger than the dance's own steps (into it, the model
    # continues from the kept frames it was given; this made-up take does not)
    s = steps(out)
    assert max(s[59], s[99]) <= 2.0 * np.percentile(steps(dance), 95)
    moved = placed(take, dance, 29)  # the take put where the dance stands and facing its way, not 3.6 m away
    assert np.abs(moved.root[29, [0, 2]] - dance.root[29, [0, 2]]).max() < 1e-9
    assert abs(heading(moved.rotations[29, 0]) - heading(dance.rotations[29, 0])) < 1e-9
