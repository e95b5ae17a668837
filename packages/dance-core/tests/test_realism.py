"""Realism statistics against real dance and beat locking from the body's own movement: values on
motions whose answer is known, and the controls the measures exist to fail."""

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.evaluation.realism import (
    STATISTICS,
    body_beats,
    body_locking,
    realism_distance,
    weight_changes,
    window_statistics,
)
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24

FPS = 30.0
SKEL = dance24()
J = {n: i for i, n in enumerate(SKEL.names)}


def rest(seconds=8.0):
    n = int(seconds * FPS)
    return np.zeros((n, len(SKEL), 3)), np.tile(SKEL.offsets[0], (n, 1))


def moving(rot, root):
    return Motion(SKEL, FPS, root, expmap_to_quat(rot)).positions()


def column(windows, name):
    return windows[:, STATISTICS.index(name)]


def test_a_rigid_t_pose_has_straight_limbs_raised_arms_and_no_steps():
    rot, root = rest()
    w = window_statistics(moving(rot, root), FPS, SKEL.names)
    assert w.shape == (5, len(STATISTICS))  # 8 s: windows of 4 s every second
    assert np.allclose(column(w, "knee_bend"), 0, atol=1e-6) and np.allclose(column(w, "elbow_bend"), 0, atol=1e-6)
    assert np.allclose(column(w, "arm_raise"), 90, atol=1e-6)
    for name in ("root_travel", "turning", "hand_speed", "foot_speed", "weight_changes", "torso_twist"):
        assert np.allclose(column(w, name), 0, atol=1e-9), name


def test_bent_elbows_knees_travel_and_turning_are_measured_in_their_units():
    rot, root = rest()
    t = np.arange(len(root)) / FPS
    for side in "LR":
        rot[:, J[f"{side}_Elbow"], 1] = np.radians(90) * (1 if side == "L" else -1)  # forearm swung forward
        rot[:, J[f"{side}_Knee"], 0] = np.radians(40)  # shank back
    root[:, 0] += 0.45 * t  # walking 0.45 m/s to the side
    rot[:, 0, 1] = 0.5 * t  # turning 0.5 rad/s
    w = window_statistics(moving(rot, root), FPS, SKEL.names)
    assert np.allclose(column(w, "elbow_bend"), 90, atol=0.5)
    assert np.allclose(column(w, "knee_bend"), 40, atol=0.5)
    assert np.allclose(column(w, "turning"), 0.5, atol=0.01)
    # 0.45 m/s over a leg the measure estimates from the (knee-bent) standing hip height: about 0.9 m
    assert np.all(np.abs(column(w, "root_travel") - 0.45 / 0.9) < 0.1)


def test_weight_changes_count_real_shifts_not_level_sliding():
    low, high = 0.07, 0.2
    steps = np.array([[low, high]] * 10 + [[high, low]] * 10 + [[low, high]] * 10)
    assert weight_changes(steps).sum() == 2
    level = np.stack([np.full(30, 0.07), 0.07 + 0.01 * np.sin(np.arange(30))], axis=1)  # within 3 % of a leg
    assert weight_changes(level / 0.9).sum() == 0


def test_the_distance_is_zero_for_the_same_set_and_grows_with_difference():
    rng = np.random.default_rng(0)
    ref = rng.normal(size=(400, 4)) * [1, 2, 3, 4] + [10, 20, 30, 40]
    same = rng.normal(size=(400, 4)) * [1, 2, 3, 4] + [10, 20, 30, 40]
    off = same + [0, 0, 0, 8]  # two standard deviations along one statistic
    assert realism_distance(ref, ref) == pytest.approx(0, abs=1e-6)
    assert realism_distance(same, ref) < 0.2
    assert realism_distance(off, ref) == pytest.approx(4.0, rel=0.15)  # (8 / 4)^2
    with pytest.raises(DataError, match="at least 2 windows"):
        realism_distance(ref[:1], ref)


def limbs_on_beats(beats, seconds=12.0, offset=0.0):
    """Arms and a knee swinging out on one beat and back on the next, pausing (an accent) on every beat,
    shifted by ``offset`` s."""
    rot, root = rest(seconds)
    t = np.arange(len(root)) / FPS - offset
    period = float(np.median(np.diff(beats)))
    swing = 0.6 * (1 - np.cos(np.pi * (t - beats[0]) / period)) / 2  # still at every beat, fastest between
    rot[:, J["L_Shoulder"], 2] = swing
    rot[:, J["R_Shoulder"], 2] = -swing
    rot[:, J["L_Knee"], 0] = swing
    return moving(rot, root)


def test_body_locking_hears_accents_on_the_beat_and_fails_the_controls():
    beats = np.arange(0.25, 12.0, 0.5)
    on = body_locking(limbs_on_beats(beats), FPS, SKEL.names, beats)
    assert on["locking"] > 0.9 and on["control"] < 0.5 and 0.7 < on["accents_per_beat"] < 1.3
    off = body_locking(limbs_on_beats(beats, offset=0.25), FPS, SKEL.names, beats)
    assert off["locking"] < -0.9  # every accent on the off-beat
    # the statue: a rigid figure bouncing and swaying with the beat moves no limb, so it has no accents
    rot, root = rest(12.0)
    t = np.arange(len(root)) / FPS
    root[:, 1] -= 0.04 * (1 + np.cos(2 * np.pi * (t - 0.25) / 0.5)) / 2
    root[:, 0] += 0.1 * np.sin(np.pi * t)
    rot[:, 0, 1] = 0.3 * np.sin(np.pi * t)  # and turning
    assert len(body_beats(moving(rot, root), FPS, SKEL.names)) == 0
    statue = body_locking(moving(rot, root), FPS, SKEL.names, beats)
    assert np.isnan(statue["locking"]) and statue["accents_per_beat"] == 0


def test_joints_that_cannot_be_mapped_are_one_line():
    with pytest.raises(DataError) as err:
        window_statistics(np.zeros((200, 3, 3)), FPS, ["a", "b", "c"], where="odd.bvh")
    assert "\n" not in str(err.value) and "odd.bvh" in str(err.value)
