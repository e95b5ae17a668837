"""The dance-quality measures (dance_core.evaluation.quality) on crafted motion with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dance_core.evaluation import quality as Q
from dance_core.motion.motion import Motion
from dance_core.motion.skeletons import SMPL_NAMES, SMPL_PARENTS, dance24

REST = dance24().rest_positions()


FPS = 60.0
FEET = (7, 10, 8, 11)


def standing(frames: int, lift: float = 0.0) -> np.ndarray:
    """The SMPL rest pose for ``frames`` frames, its lowest foot joint at height ``lift``."""
    pose = REST - np.array([0.0, REST[list(FEET), 1].min() - lift, 0.0])
    return np.repeat(pose[None], frames, axis=0).copy()


def bouncing(seconds: float, period: float, start: float = 0.3, depth: float = 0.06, fps: float = FPS):
    """Standing, the whole body except the feet dipping by ``depth`` once per beat (lowest on each beat)."""
    t = np.arange(int(seconds * fps)) / fps
    p = standing(len(t))
    dip = -0.5 * depth * (1 + np.cos(2 * np.pi * (t - start) / period))  # minimum -depth at start + k*period
    upper = [j for j in range(24) if j not in FEET]
    p[:, upper, 1] += dip[:, None]
    beats = start + period * np.arange(int((seconds - start) / period) + 1)
    return p, beats[beats < seconds]


def test_phases_and_locking_of_a_perfect_and_a_random_beat():
    beats = np.arange(0.0, 10.0, 0.5)
    assert Q.beat_phases([0.1, 0.6, 9.8, -1.0], beats) == pytest.approx([0.2, 0.2])
    assert Q.phase_locking(beats[:-1] + 0.1, beats) == pytest.approx(1.0)
    assert Q.phase_locking(np.concatenate([beats[:-1], beats[:-1] + 0.25]), beats) == pytest.approx(0.0, abs=1e-9)
    assert np.isnan(Q.phase_locking([20.0], beats))
    rng = np.random.default_rng(0)
    assert Q.phase_locking(np.sort(rng.uniform(0, 9.5, 400)), beats) < 0.15


def test_wrong_tempo_grid_spans_the_beats_at_113_percent():
    beats = 1.0 + 0.5 * np.arange(41)  # 1 .. 21 s
    grid = Q.wrong_tempo_grid(beats)
    assert grid[0] == 1.0
    assert np.diff(grid) == pytest.approx(np.full(len(grid) - 1, 0.5 / 1.13))
    assert grid[-1] <= beats[-1] < grid[-1] + 0.5 / 1.13


def test_a_dance_bouncing_on_the_beat_locks_and_its_control_does_not():
    positions, beats = bouncing(60.0, period=0.47)
    hips = Q.hip_height_beats(positions, FPS)
    assert len(hips) == pytest.approx(len(beats), abs=1)
    scores = Q.beat_locking(positions, FPS, beats)
    assert scores["locking_hips"] > 0.95
    assert scores["locking"] > 0.95
    assert scores["control_hips"] < 0.2
    assert scores["locking_ratio"] > 3
    rng = np.random.default_rng(1)
    random_beats = np.sort(rng.uniform(0, 60, len(beats)))
    assert Q.phase_locking(hips, random_beats) < 0.25


def test_a_bounce_at_another_tempo_does_not_lock():
    positions, _ = bouncing(60.0, period=0.41)
    _, beats = bouncing(60.0, period=0.53)
    assert Q.beat_locking(positions, FPS, beats)["locking"] < 0.3


def test_floating_below_floor_and_ten_second_medians():
    grounded = standing(1200)
    assert Q.floating_fraction(grounded, FEET) == 0.0
    assert Q.below_floor_fraction(grounded, FEET) == 0.0
    flying = standing(1200, lift=0.2)
    assert Q.floating_fraction(flying, FEET) == 1.0
    assert Q.stretch_medians(flying, FPS, FEET) == pytest.approx([0.2, 0.2])
    sunk = standing(1200, lift=-0.1)
    assert Q.below_floor_fraction(sunk, FEET) == 1.0 and Q.floating_fraction(sunk, FEET) == 0.0
    # one foot raised high, the other on the floor: not floating
    one = standing(100)
    one[:, [7, 10], 1] += 0.3
    assert Q.floating_fraction(one, FEET) == 0.0
    # the second 10 s float: 50 % of frames, and the worst stretch's median is the lift
    mixed = np.concatenate([standing(600), standing(600, lift=0.15)])
    assert Q.floating_fraction(mixed, FEET) == pytest.approx(0.5)
    assert Q.quality_scores(mixed, FPS, np.arange(0, 20, 0.5))["worst_stretch"] == pytest.approx(0.15)


def test_on_the_balls_of_the_feet_the_soles_are_on_the_floor():
    """Heels raised 8 cm with the toe tips on the floor: the ankle and ball joints are both above 5 cm,
    so the joints alone call it floating; the soles grounding finds (its End Sites) are on the floor."""
    from dance_core.motion.grounding import soles

    skel = dance24()
    n = 40
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (n, len(skel), 1))
    for side in ("L_Ankle", "R_Ankle"):  # the foot pitched down until the toe tip touches the floor again
        rot[:, skel.names.index(side)] = Rotation.from_euler("x", 50, degrees=True).as_quat()
    motion = Motion(skel, FPS, np.tile(skel.offsets[0], (n, 1)), rot)
    heights = soles(motion)
    lift = heights.min() - soles(Motion(skel, FPS, motion.root, np.tile([0.0, 0, 0, 1], (n, len(skel), 1)))).min()
    motion.root[:, 1] -= lift  # lowered so that the lowest sole point is on the floor
    p = motion.positions()
    feet = (skel.names.index("L_Ankle"), skel.names.index("L_Foot"), skel.names.index("R_Ankle"),
            skel.names.index("R_Foot"))
    assert Q.lowest_foot(p, feet).min() > 0.05  # every joint of the feet above 5 cm ...
    assert Q.floating_fraction(p, feet) == 1.0
    on_floor = soles(motion)
    assert np.allclose(on_floor.min(1), 0.0, atol=1e-6)  # ... but the soles are on the floor
    assert Q.floating_fraction(p, feet, heights=on_floor) == 0.0
    scores = Q.quality_scores(p, FPS, np.arange(0, 2, 0.5), skel.names, soles=on_floor)
    assert scores["float"] == 0.0 and scores["worst_stretch"] == pytest.approx(0.0, abs=1e-6)


def test_stretches_merge_a_short_remainder():
    assert Q.stretches(1250, 60.0) == [slice(0, 600), slice(600, 1250)]
    assert Q.stretches(1500, 60.0) == [slice(0, 600), slice(600, 1200), slice(1200, 1500)]
    assert Q.stretches(100, 60.0) == [slice(0, 100)]


def test_foot_skating_is_the_speed_of_the_foot_on_the_floor():
    frames = 300
    t = np.arange(frames) / FPS
    still = standing(frames)
    assert Q.foot_skating(still, FPS, FEET) == pytest.approx(0.0)
    sliding = standing(frames)
    sliding[:, :, 0] += 0.8 * t[:, None]  # the whole body glides at 0.8 m/s
    assert Q.foot_skating(sliding, FPS, FEET) == pytest.approx(0.8)
    # a raised foot may move: only the planted one counts
    swinging = standing(frames)
    swinging[:, [7, 10], 1] += 0.2
    swinging[:, [7, 10], 2] += 0.5 * np.sin(2 * np.pi * t)[:, None]
    assert Q.foot_skating(swinging, FPS, FEET) == pytest.approx(0.0)
    assert np.isnan(Q.foot_skating(standing(frames, lift=0.3), FPS, FEET))


def test_jerk_of_a_sine_matches_its_derivative_and_noise_raises_it():
    t = np.arange(1200) / FPS
    amp, omega = 0.1, 2 * np.pi * 1.5
    p = np.zeros((len(t), 2, 3))
    p[:, :, 0] = amp * np.sin(omega * t)[:, None]
    s = Q.smoothness(p, FPS)
    assert s["speed"] == pytest.approx(amp * omega * 2 / np.pi, rel=0.01)
    assert s["acceleration"] == pytest.approx(amp * omega**2 * 2 / np.pi, rel=0.01)
    assert s["jerk"] == pytest.approx(amp * omega**3 * 2 / np.pi, rel=0.02)
    noisy = p + np.random.default_rng(0).normal(0, 0.002, p.shape)
    assert Q.smoothness(noisy, FPS)["jerk"] > 10 * s["jerk"]


def test_speed_drift_and_foot_trend():
    t = np.arange(int(90 * FPS)) / FPS
    p = standing(len(t))
    freq = np.where(t < 45, 1.0, 2.0)  # the dancer moves twice as fast in the second half
    p[:, :, 2] += (0.1 * np.sin(2 * np.pi * np.cumsum(freq) / FPS))[:, None]
    assert Q.speed_drift(p, FPS) == pytest.approx(2.0, rel=0.02)
    assert Q.speed_drift(p[: int(40 * FPS)], FPS) == pytest.approx(1.0, rel=0.02)  # halves, both slow
    rising = p.copy()
    rising[:, :, 1] += (0.02 * t / 60)[:, None]  # 2 cm per minute
    assert Q.foot_height_trend(rising, FPS, FEET) == pytest.approx(0.02, rel=1e-6)
    assert Q.foot_height_trend(p, FPS, FEET) == pytest.approx(0.0, abs=1e-9)


def test_bone_lengths_of_rigid_forward_kinematics_are_constant():
    rng = np.random.default_rng(0)
    frames = 200
    rotations = Rotation.from_rotvec(rng.normal(0, 0.6, (frames * 24, 3))).as_quat().reshape(frames, 24, 4)
    root = rng.normal(0, 0.5, (frames, 3))
    positions = Motion(dance24(), FPS, root, rotations).positions()
    assert Q.bone_length_constancy(positions, SMPL_PARENTS) < 1e-9
    stretched = positions.copy()
    stretched[::2, 20] += 0.05  # the left wrist jumps 5 cm every other frame
    assert Q.bone_length_constancy(stretched, SMPL_PARENTS) > 0.05


def test_diversity_of_samples():
    base = standing(300)
    assert Q.diversity([base]) != Q.diversity([base])  # NaN for one sample
    assert Q.diversity([base, base.copy()]) == pytest.approx(0.0)
    moved = base + np.array([3.0, 0.0, 1.0])  # same pose elsewhere on the floor
    assert Q.diversity([base, moved]) == pytest.approx(0.0)
    raised = base.copy()
    raised[:, 20, 1] += 0.3  # the left wrist 30 cm higher
    assert Q.diversity([base, raised, raised.copy()]) == pytest.approx(2 / 3 * 0.3)
    positions, _ = bouncing(10.0, 0.5)
    other, _ = bouncing(10.0, 0.37)
    assert Q.diversity([positions, other], FPS, features="kinetic") > 0
    assert Q.diversity([positions, positions], FPS, features="kinetic") == pytest.approx(0.0)


def test_feet_by_name_and_all_scores_of_a_bouncing_dance():
    positions, beats = bouncing(70.0, period=0.5)
    assert Q.feet_of(positions, SMPL_NAMES) == FEET
    scores = Q.quality_scores(positions, FPS, beats, SMPL_NAMES, SMPL_PARENTS)
    assert scores["locking"] > 0.95
    assert scores["float"] == 0.0 and scores["below_floor"] == 0.0
    assert scores["skating"] == pytest.approx(0.0, abs=1e-9)
    assert scores["drift"] == pytest.approx(1.0, rel=0.02)
    assert np.isnan(scores["drift_60"])
    assert scores["seconds"] == pytest.approx(70.0)
    assert scores["bone"] > 0  # the dip stretches the legs: the crafted motion is not rigid
