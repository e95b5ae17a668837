"""The paper's slerp editing baseline: a text-driven clip spliced into a dance with 10-frame transitions."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dance_core import DataError, Motion
from dance_core.motion.skeletons import dance24
from dance_tokens.slerp import heading, slerp, slerp_splice


def angle(a, b):
    return 2 * np.arccos(np.clip(np.abs((a * b).sum(-1)), 0, 1))


def test_slerp_moves_at_constant_speed_along_the_short_arc():
    q0 = Rotation.from_rotvec([0.0, 0.3, 0.0]).as_quat()
    q1 = -Rotation.from_rotvec([0.0, 1.5, 0.2]).as_quat()  # the other hemisphere: same rotation
    w = np.linspace(0, 1, 6)
    q = slerp(q0, q1, w)
    assert q.shape == (6, 4) and np.allclose(np.linalg.norm(q, axis=-1), 1)
    assert np.allclose(q[0], q0) and np.allclose(angle(q[-1], q1), 0, atol=1e-7)
    steps = angle(q[1:], q[:-1])
    assert np.allclose(steps, steps[0]) and np.isclose(steps.sum(), angle(q0, q1))
    assert np.allclose(slerp(q0, q0, w), q0)  # identical ends


def motion(frames, seed, yaw=0.0, x=0.0):
    rng = np.random.default_rng(seed)
    rot = Rotation.from_rotvec(rng.normal(0, 0.3, (frames, 24, 3)).reshape(-1, 3)).as_quat().reshape(frames, 24, 4)
    rot[:, 0] = (Rotation.from_rotvec([0, yaw, 0]) * Rotation.from_quat(rot[:, 0])).as_quat()
    root = np.stack([x + np.linspace(0, 1, frames), np.full(frames, 0.9), np.linspace(0, 2, frames)], 1)
    return Motion(dance24(), 30.0, root, rot)


def test_splice_places_the_clip_and_bridges_it_with_slerp():
    dance, clip = motion(120, 0), motion(40, 1, yaw=2.0, x=5.0)
    out = slerp_splice(dance, clip, start=30, transition=10)
    assert out.n_frames == 120
    assert np.array_equal(out.rotations[:30], dance.rotations[:30]) and np.array_equal(out.root[:30], dance.root[:30])
    # the clip: its own joint rotations, standing where the dancer stood and facing where it faced
    inside = slice(40, 80)
    assert np.allclose(out.rotations[inside, 1:], clip.rotations[:, 1:])
    assert np.allclose(out.root[40, [0, 2]], dance.root[29, [0, 2]]) and np.isclose(out.root[40, 1], clip.root[0, 1])
    assert np.isclose(heading(out.rotations[40, 0]), heading(dance.rotations[29, 0]))
    steps = np.diff(out.root[inside], axis=0)
    assert np.allclose(np.linalg.norm(steps, axis=1), np.linalg.norm(np.diff(clip.root, axis=0), axis=1))
    # 10 transition frames, slerped joint by joint from the last dance frame to the clip's first
    for k in range(10):
        w = (k + 1) / 11
        expected = slerp(dance.rotations[29], out.rotations[40], np.array([w]))[0]
        assert np.allclose(angle(out.rotations[30 + k], expected), 0, atol=1e-6)
    # then back to the dance, which resumes where time has got to, from where the clip ended
    assert np.array_equal(out.rotations[90:], dance.rotations[90:])
    assert np.allclose(out.root[90:, [0, 2]] - out.root[90, [0, 2]], dance.root[90:, [0, 2]] - dance.root[90, [0, 2]])
    assert np.allclose(out.root[90, [0, 2]], out.root[79, [0, 2]])
    jumps = np.linalg.norm(np.diff(out.root, axis=0), axis=1)
    assert jumps.max() < 0.1  # no teleport anywhere


def test_splice_near_the_end_is_cut_and_bad_input_is_one_line():
    dance, clip = motion(60, 0), motion(40, 1)
    assert slerp_splice(dance, clip, start=50).n_frames == 60
    with pytest.raises(DataError, match="start"):
        slerp_splice(dance, clip, start=0)
    positions = Motion(dance24(), 30.0, dance.root, joint_positions=np.zeros((60, 24, 3)))
    with pytest.raises(DataError, match="rotations"):
        slerp_splice(positions, clip, start=10)
