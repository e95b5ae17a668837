import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.motion.resample import resample_array
from dance_core.motion.root import deltas_to_root, heading, root_to_deltas
from dance_core.motion.rotations import quat_mul, yaw_quat
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import body25, dance24, transflower21


def wandering(n=240, seed=0):
    """A root that walks, turns past +-pi several times and tilts."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 60
    yaw = 5.0 * t + 0.5 * np.sin(3 * t)
    tilt = Rotation.from_rotvec(np.stack([0.2 * np.sin(2 * t), 0 * t, 0.1 * np.cos(t)], -1)).as_quat()
    rot = quat_mul(yaw_quat(yaw), tilt)
    walk = np.cumsum(rng.normal(0, 0.02, (n, 2)), axis=0)
    pos = np.stack([walk[:, 0], 0.9 + 0.05 * np.sin(7 * t), walk[:, 1]], -1)
    return pos, rot


def test_ground_deltas_invert_exactly_to_the_same_trajectory():
    pos, rot = wandering()
    deltas, local, start = root_to_deltas(pos, rot)
    assert deltas.shape == (240, 4) and np.allclose(deltas[0, [0, 1, 3]], 0)
    np.testing.assert_allclose(deltas[:, 2], pos[:, 1])
    back_pos, back_rot = deltas_to_root(deltas, local, start)
    np.testing.assert_allclose(back_pos, pos, atol=1e-10)
    assert np.abs(np.abs((back_rot * rot).sum(-1)) - 1).max() < 1e-10


def test_deltas_do_not_depend_on_where_the_dancer_starts_or_faces():
    pos, rot = wandering()
    turn = yaw_quat(np.full(len(pos), 1.3))
    moved = Rotation.from_quat(turn[0]).apply(pos) + np.array([4.0, 0.0, -2.0])
    d1, l1, _ = root_to_deltas(pos, rot)
    d2, l2, s2 = root_to_deltas(moved, quat_mul(turn, rot))
    np.testing.assert_allclose(d1, d2, atol=1e-10)
    assert np.abs(np.abs((l1 * l2).sum(-1)) - 1).max() < 1e-10
    assert abs(s2.x - moved[0, 0]) < 1e-12


def test_heading_relative_root_rotation_has_no_yaw():
    pos, rot = wandering()
    _, local, _ = root_to_deltas(pos, rot)
    np.testing.assert_allclose(heading(local), 0.0, atol=1e-9)


def motion_on(skel, n=30, seed=0):
    q = Rotation.random(n * len(skel), random_state=seed).as_quat().reshape(n, len(skel), 4)
    small = Rotation.from_quat(q.reshape(-1, 4)).as_rotvec().reshape(n, len(skel), 3) * 0.3
    return Motion(skel, 30.0, np.random.default_rng(seed).normal(size=(n, 3)),
                  Rotation.from_rotvec(small.reshape(-1, 3)).as_quat().reshape(n, len(skel), 4))


def symmetric(skel):
    """The skeleton with each left joint's offset mirrored from its right counterpart."""
    pairs = skel.mirror_pairs()
    off = skel.offsets.copy()
    for j, k in enumerate(pairs):
        if k != j and "R" in skel.names[j][:5]:
            off[j] = skel.offsets[k] * np.array([-1, 1, 1])
        elif k == j:
            off[j, 0] = 0.0
    return Skeleton(skel.names, skel.parents, off, name=skel.name)


@pytest.mark.parametrize("make", [dance24, transflower21])
def test_mirroring_reflects_positions_and_swaps_sides(make):
    skel = symmetric(make())
    m = motion_on(skel)
    pairs = skel.mirror_pairs()
    assert sum(p != j for j, p in enumerate(pairs)) >= 8
    mirrored = m.mirrored().positions()
    expected = m.positions()[:, pairs] * np.array([-1, 1, 1])
    np.testing.assert_allclose(mirrored, expected, atol=1e-9)
    np.testing.assert_allclose(m.mirrored().mirrored().positions(), m.positions(), atol=1e-9)


def test_builtin_skeletons_pair_left_and_right():
    names = body25().names
    pairs = body25().mirror_pairs()
    assert names[pairs[names.index("LWrist")]] == "RWrist" and names[pairs[names.index("Nose")]] == "Nose"
    smpl = dance24()
    assert smpl.names[smpl.mirror_pairs()[smpl.index("L_Hand")]] == "R_Hand"


def test_resampling_keeps_slow_motion_and_removes_what_the_new_rate_cannot_hold():
    fps, n = 60.0, 600
    t = np.arange(n) / fps
    slow, fast = np.sin(2 * np.pi * 1.5 * t), np.sin(2 * np.pi * 14.0 * t)  # 14 Hz aliases at 20 fps
    out = resample_array(np.stack([slow, fast], -1), fps, 20.0)
    assert out.shape == (200, 2)
    t20 = np.arange(200) / 20
    np.testing.assert_allclose(out[20:-20, 0], np.sin(2 * np.pi * 1.5 * t20)[20:-20], atol=0.02)
    assert np.abs(out[20:-20, 1]).max() < 0.05


def test_motion_resample_slerps_rotations_and_keeps_source_frames():
    m = motion_on(dance24(), n=31)
    up = m.resample(90.0)  # 3x: every third frame is a source frame
    assert up.n_frames == 93 and up.fps == 90.0
    assert np.abs(np.abs((up.rotations[::3] * m.rotations).sum(-1)) - 1).max() < 1e-9
    mid = up.rotations[1]
    a, b = m.rotations[0], m.rotations[1]
    expected = Rotation.from_quat(a[0]) * Rotation.from_rotvec(
        (Rotation.from_quat(a[0]).inv() * Rotation.from_quat(b[0])).as_rotvec() / 3)
    assert abs(abs(np.dot(mid[0], expected.as_quat())) - 1) < 1e-9
    down = m.resample(10.0)
    assert down.n_frames == 11 and np.allclose(np.linalg.norm(down.rotations, axis=-1), 1)


def test_bad_motion_is_a_clear_error():
    with pytest.raises(DataError, match="rotations"):
        Motion(dance24(), 30.0, np.zeros((4, 3)), np.zeros((4, 5, 4)))
    with pytest.raises(DataError, match="parent"):
        Skeleton(["a", "b"], [-1, 1], np.zeros((2, 3)))
