"""Metrics that measure what the papers meant: heading-free FPD/FMD, freezing relative to the reference's
speed, beat phase locking, and diversity across samples of one song."""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

from dance_core.evaluation.canon import canonical_windows
from dance_core.evaluation.diversity import SampleDiversity, songs_of
from dance_core.evaluation.metrics import BeatLocking, BeatOffset, FrechetPose, Freezing, pose_windows
from dance_core.evaluation.report import build_metric, evaluate
from dance_core.motion.skeletons import dance24
from dance_core.protocols import JointClip
from dance_core.registry import get_registry
from dance_core.testing import check_metric

REST = dance24().rest_positions()

FPS = 30.0
BPM = 120.0


def turned(p: np.ndarray, yaw, shift) -> np.ndarray:
    """Positions ``(T, J, 3)`` turned about Y by ``yaw`` and moved by ``shift`` (x, z) on the floor;
    ``yaw`` and the shifts may be per-frame arrays."""
    c, s = np.asarray(np.cos(yaw))[..., None], np.asarray(np.sin(yaw))[..., None]
    out = p.copy()
    out[..., 0] = c * p[..., 0] + s * p[..., 2] + np.asarray(shift[0])[..., None]
    out[..., 2] = -s * p[..., 0] + c * p[..., 2] + np.asarray(shift[1])[..., None]
    return out


def dancer(seed: int, seconds: float = 8.0) -> JointClip:
    """A dancer on the default skeleton (SMPL-24 joints) of one style: limbs swinging every two beats, a
    bounce lowest on the beat, turning back and forth while travelling (Y up, metres, 120 BPM beats)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FPS)) / FPS
    f = BPM / 60.0
    rest = REST - REST[:, 1].min()
    style = np.random.default_rng(0)  # one style: every dancer swings the same limbs, by its own amount
    amp = style.normal(0, 0.08, size=(24, 3)) * rng.uniform(0.7, 1.3)
    phase = style.uniform(0, 2 * np.pi, size=(24, 3)) + rng.normal(0, 0.3, size=(24, 3))
    body = rest[None] + amp[None] * np.sin(np.pi * f * t[:, None, None] + phase[None])
    body[:, :, 1] += 0.05 * np.cos(2 * np.pi * f * t)[:, None]
    body[..., [0, 2]] -= body[:, :1, [0, 2]]
    yaw = 0.8 * np.sin(2 * np.pi * 0.2 * t + seed)
    path = (0.3 * np.sin(2 * np.pi * 0.1 * t + seed), 0.3 * np.cos(2 * np.pi * 0.13 * t))
    return JointClip(f"d{seed}", turned(body, yaw, path), FPS, music_beats=np.arange(0, seconds, 1 / f))


def moved(clip: JointClip, positions: np.ndarray, name: str | None = None) -> JointClip:
    """The clip with other positions (and optionally another name)."""
    return JointClip(name or clip.name, positions, clip.fps, clip.joints, clip.music_beats)


@pytest.fixture(scope="module")
def sets():
    reference = [dancer(s) for s in range(6)]
    generated = [dancer(s) for s in range(6, 10)]
    rng = np.random.default_rng(1)
    rotated = [moved(c, turned(c.positions, rng.uniform(-np.pi, np.pi), rng.uniform(-5, 5, 2))) for c in generated]
    frozen = [moved(c, np.repeat(c.positions[:1], len(c.positions), axis=0)) for c in generated]
    return reference, generated, rotated, frozen


# --- FPD / FMD --------------------------------------------------------------------------------


def test_windows_are_in_the_body_frame_of_their_middle_frame(sets):
    _, (clip, *_), (turned_clip, *_), _ = sets
    w = canonical_windows(clip.positions, 3, 1, 2)
    assert w.shape == (len(clip.positions) - 2, 3, 24, 3)
    assert w[:, 1, 0, [0, 2]] == pytest.approx(np.zeros((len(w), 2)), abs=1e-12)  # root over the origin
    np.testing.assert_allclose(canonical_windows(turned_clip.positions, 3, 1, 2), w, atol=1e-9)
    # the window's own turning stays in: the first and last frames are not facing +Z
    assert np.abs(w[:, 0, 1, 2] - w[:, 0, 2, 2]).max() > 1e-3
    rows, notes = pose_windows([clip, turned_clip], 3, "FMD")
    assert not notes and rows[0].shape == (len(w), 3 * 24 * 3)
    np.testing.assert_allclose(rows[1], rows[0], atol=1e-9)


def test_a_turned_and_moved_copy_scores_the_same_fpd_and_fmd_and_a_frozen_pose_far_worse(sets):
    reference, generated, rotated, frozen = sets
    for span in (1, 3):
        metric = FrechetPose(span)
        danced, turned_copy, still = (metric(s, reference).values[metric.value] for s in (generated, rotated, frozen))
        assert turned_copy == pytest.approx(danced, rel=1e-5)
        assert still > 20 * danced
    # FMD: danced 0.115, turned and moved 0.115, frozen first pose 4.14


def test_the_compat_variant_reproduces_the_world_oriented_numbers(sets):
    reference, generated, rotated, frozen = sets
    fpd, fmd = FrechetPose(1, compat=True), FrechetPose(3, compat=True)
    # the values of the earlier definition (world orientation, root's horizontal position removed), on
    # dance24's rest pose (on SMPL's template they were 0.02336 and 0.07198)
    assert fpd(generated, reference).values["FPD"] == pytest.approx(0.02324808047797866, rel=1e-6)
    assert fmd(generated, reference).values["FMD"] == pytest.approx(0.07168801946528536, rel=1e-6)
    # ... under which a frozen first pose beats the same dances facing elsewhere (3.06 vs 17.8)
    assert fmd(frozen, reference).values["FMD"] < fmd(rotated, reference).values["FMD"]
    # dance evaluate --compat reaches it through the registry
    registry = get_registry()
    assert build_metric("fmd", registry, compat=True).compat and not build_metric("fmd", registry).compat
    report = evaluate(generated, reference, ["fmd"], compat=True, registry=registry)
    assert report.values()["FMD"] == pytest.approx(0.07168801946528536, rel=1e-6)


def test_a_skeleton_without_hips_falls_back_to_world_orientation_with_a_note():
    clips = [JointClip(f"s{k}", np.random.default_rng(k).normal(size=(20, 6, 3)), FPS) for k in range(2)]
    result = FrechetPose(3)(clips, clips)
    assert result.values["FMD"] == pytest.approx(0.0, abs=1e-9)
    assert "not heading-free" in result.notes[0] and "6 joints" in result.notes[0]


# --- freezing ---------------------------------------------------------------------------------


def test_a_held_pose_is_frozen_relative_to_the_reference_and_a_slow_groove_is_not(sets):
    reference, (clip, *_), _, _ = sets
    p = clip.positions
    t = np.arange(len(p)) / FPS
    sway = p[:1] + 0.01 * np.sin(np.pi * t)[:, None, None] * np.array([1.0, 0.0, 0.0])  # 1 cm, 0.5 Hz
    cases = {
        "held": moved(clip, sway, "held"),  # a held pose that breathes: peak speed 3 cm/s
        "still": moved(clip, np.repeat(p[:1], len(p), axis=0), "still"),
        "slow": moved(clip, p[:1] + 0.3 * (p - p[:1]), "slow"),  # the dance at 30 % of its amplitude
        "danced": moved(clip, p, "danced"),
    }
    result = Freezing()(list(cases.values()), reference)
    pff = {name: (v["PFF"], v["PFF_rel"]) for name, v in result.per_clip.items()}
    # (TM2D's absolute PFF, PFF relative to the reference's speed), %
    assert pff == {"held": (0.0, 100.0), "still": (100.0, 100.0), "slow": (0.0, 0.0), "danced": (0.0, 0.0)}
    assert result.values["PFF"] == pytest.approx(25.0) and result.values["PFF_rel"] == pytest.approx(50.0)
    # 0.1 x the reference's median largest joint speed (1.48 m/s)
    assert 0.1 < result.values["PFF_rel_threshold"] < 0.2
    alone = Freezing()([cases["held"]])
    assert "PFF_rel" not in alone.values and "no reference set" in alone.notes[0]


# --- beat locking -----------------------------------------------------------------------------


def bouncing(seed: int, phase: float, seconds: float = 16.0) -> JointClip:
    """The dancer with its bounce lowest at ``phase`` (fraction of a beat) after every beat."""
    c = dancer(seed, seconds)
    t = np.arange(len(c.positions)) / FPS
    p = c.positions.copy()
    p[:, :, 1] += 0.05 * (np.cos(2 * np.pi * (BPM / 60 * t - phase)) - np.cos(2 * np.pi * BPM / 60 * t))[:, None]
    return moved(c, p)


def random_mover(seed: int, seconds: float = 16.0) -> JointClip:
    """A body whose joints and height wander smoothly at random, unrelated to the beat."""
    c = dancer(seed, seconds)
    rng = np.random.default_rng(100 + seed)
    n = len(c.positions)
    p = c.positions[:1] + gaussian_filter1d(rng.normal(0, 0.3, (n, 24, 3)), 3, axis=0)
    p[:, :, 1] += gaussian_filter1d(rng.normal(0, 0.2, n), 3)[:, None]
    return moved(c, p)


def test_beat_locking_is_high_at_any_constant_phase_and_low_for_random_beats():
    offsets = []
    for phase in (0.0, 0.25, 0.5, 0.8):
        clips = [bouncing(s, phase) for s in range(3)]
        result = BeatLocking()(clips)
        assert result.values["beat_locking"] > 0.95, phase
        assert result.values["beat_locking_control"] < 0.2, phase  # not locked to a wrong tempo
        offsets.append(BeatOffset()(clips).values["beat_offset_mean"])
    assert max(offsets) - min(offsets) > 0.1  # the offset column depends on the phase (0.05 to 0.25 s)
    random = BeatLocking()([random_mover(s) for s in range(3)])
    assert random.values["beat_locking"] < 0.3  # 0.16
    assert set(random.per_clip["d0"]) == {
        "beat_locking",
        "beat_locking_control",
        "beat_locking_speed",
        "beat_locking_hips",
    }


# --- sample diversity -------------------------------------------------------------------------


def test_samples_of_one_song_identical_score_zero_and_different_dances_more(sets):
    reference, generated, rotated, _ = sets
    a, b = generated[:2]
    same = [moved(a, a.positions, "s0-0"), moved(rotated[0], rotated[0].positions, "s0-1")]
    same += [moved(b, b.positions, "s1-0"), moved(b, b.positions, "s1-1")]
    assert songs_of(same) == {"s0": [0, 1], "s1": [2, 3]}
    result = SampleDiversity()(same, reference)
    assert result.values["Div_sample_pose"] == pytest.approx(0.0, abs=1e-6)  # m
    assert result.values["Div_sample_k"] == pytest.approx(0.0, abs=1e-6)
    assert result.values["sample_songs"] == 2.0 and not result.notes
    different = [moved(c, c.positions, f"s{k // 2}-{k % 2}") for k, c in enumerate([*generated, reference[0]])]
    result = SampleDiversity()(different, reference)
    assert result.values["Div_sample_pose"] > 0.01 and result.values["Div_sample_k"] > 0.1
    assert result.values["sample_songs"] == 2.0 and "single sample" in result.notes[0]
    # names without samples: compared as one song, and said so
    alone = SampleDiversity()(generated)
    assert alone.values["sample_songs"] == 0.0 and "no song has two samples" in alone.notes[0]


def test_the_new_metrics_pass_the_authors_check_and_run_in_dance_evaluate(sets):
    for name in ("fpd", "fmd", "freezing", "beat-locking", "sample-diversity"):
        check_metric(name)
    reference, generated, _, _ = sets
    samples = [moved(c, c.positions, f"song-{k}") for k, c in enumerate(generated)]
    report = evaluate(samples, reference, ["freezing", "beat-locking", "sample-diversity", "fpd"])
    assert not report.skipped
    assert {"PFF_rel", "beat_locking", "Div_sample_pose", "FPD"} <= set(report.values())
