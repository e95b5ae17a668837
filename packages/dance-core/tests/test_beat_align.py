"""Beat alignment: a dance's own accents moved onto the beats by a bounded, monotone time warp that plays
every pose of the dance and adds none."""

import numpy as np

from dance_core.evaluation.realism import body_locking
from dance_core.motion.beat_align import MAX_RATE, align_to_beats, anchor_chain, nearest_beats, sample_frames
from dance_core.motion.body import body_beats
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24

FPS = 30.0
SKEL = dance24()
J = {n: i for i, n in enumerate(SKEL.names)}


def swinging(accents, seconds):
    """Arms and a knee swinging between poses, still (an accent) at each time of ``accents``."""
    n = int(seconds * FPS)
    t = np.arange(n) / FPS
    k = np.clip(np.searchsorted(accents, t, side="right") - 1, 0, len(accents) - 2)
    phase = np.clip((t - accents[k]) / (accents[k + 1] - accents[k]), 0, 1)
    swing = 0.6 * np.where(k % 2 == 0, (1 - np.cos(np.pi * phase)) / 2, (1 + np.cos(np.pi * phase)) / 2)
    rot = np.zeros((n, len(SKEL), 3))
    rot[:, J["L_Shoulder"], 2], rot[:, J["R_Shoulder"], 2], rot[:, J["L_Knee"], 0] = swing, -swing, swing
    return Motion(SKEL, FPS, np.tile(SKEL.offsets[0], (n, 1)), expmap_to_quat(rot))


def test_pairs_take_the_nearest_beat_within_reach_and_one_accent_per_beat():
    beats = np.array([1.0, 1.5, 2.0, 2.5])
    pairs = nearest_beats(np.array([1.05, 1.1, 1.74, 2.3]), beats, reach=0.45)
    # 1.05 beats 1.1 to the beat at 1.0; 1.74 is 0.24 s (0.48 of a period) from any beat: left alone
    assert pairs == {1.0: 1.05, 2.5: 2.3}
    assert nearest_beats(np.array([1.0]), np.array([1.0])) == {}  # one beat gives no period


def test_the_chain_is_monotone_within_the_rate_bound_from_start_to_end():
    rng = np.random.default_rng(3)
    targets = np.sort(rng.uniform(0.5, 19.5, 60))
    pairs = {float(b): float(b + rng.normal(0, 0.2)) for b in targets}
    src, dst = anchor_chain(pairs, 20.0, max_rate=1.3)
    assert src[0] == dst[0] == 0.0 and src[-1] == dst[-1] == 20.0
    rates = np.diff(src) / np.diff(dst)
    assert (np.diff(dst) > 0).all() and (np.diff(src) > 0).all()
    assert rates.max() <= 1.3 + 1e-9 and rates.min() >= 1 / 1.3 - 1e-9
    assert 10 < len(src) - 2 < 60  # most pairs kept, the ones that would break the bound dropped


def test_accents_off_the_beat_are_moved_onto_it_and_every_pose_is_kept():
    rng = np.random.default_rng(0)
    beats = np.arange(0.5, 16.0, 0.6)
    accents = np.concatenate([[0.0], beats + rng.uniform(-0.15, 0.15, len(beats)), [16.5]])
    motion = swinging(accents, 16.0)
    before = body_locking(motion.positions(), FPS, SKEL.names, beats)
    aligned, report = align_to_beats(motion, beats)
    after = body_locking(aligned.positions(), FPS, SKEL.names, beats)
    assert before["locking"] < 0.8 and after["locking"] > 0.9 and after["control"] < 0.5
    assert aligned.n_frames == motion.n_frames and report.moved >= 0.8 * len(beats)
    assert report.max_rate <= MAX_RATE + 1e-9 and 0.02 < report.mean_shift < 0.15
    # the swing still reaches both of its extremes: poses are re-timed, not blended away
    swing = lambda m: np.degrees(np.arccos(np.clip(m.rotations[:, J["L_Knee"], 3], -1, 1)) * 2)  # noqa: E731
    assert abs(swing(aligned).max() - swing(motion).max()) < 1.0 and swing(aligned).min() < 1.0
    # the accents found again lie on the beats
    found = body_beats(aligned.positions(), FPS, SKEL.names)
    near = np.abs(found[:, None] - beats[None]).min(1)
    assert np.median(near) < 1.5 / FPS


def test_no_beats_or_no_accents_leave_the_dance_as_it_is():
    motion = swinging(np.array([0.0, 1.0, 2.0, 3.0, 4.0]), 4.0)
    same, report = align_to_beats(motion, np.zeros(0))
    assert same is motion and report.moved == 0
    still = Motion(SKEL, FPS, np.tile(SKEL.offsets[0], (90, 1)), np.tile([0.0, 0, 0, 1], (90, len(SKEL), 1)))
    same, report = align_to_beats(still, np.arange(0.5, 3.0, 0.5))
    assert same is still and report.accents == 0


def test_sampling_between_frames_interpolates_root_and_rotations():
    motion = swinging(np.array([0.0, 1.0, 2.0]), 2.0)
    half = sample_frames(motion, np.array([0.0, 10.5, motion.n_frames - 1.0]))
    assert np.allclose(half.root[1], (motion.root[10] + motion.root[11]) / 2)
    q = half.rotations[1, J["L_Knee"]]
    angle = lambda q: 2 * np.arccos(np.clip(q[3], -1, 1))  # noqa: E731
    a, b = angle(motion.rotations[10, J["L_Knee"]]), angle(motion.rotations[11, J["L_Knee"]])
    assert abs(angle(q) - (a + b) / 2) < 1e-6 and np.allclose(half.rotations[2], motion.rotations[-1])
