"""Known-answer tests of the evaluation metrics on joint positions."""

import math

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.evaluation import beats as B
from dance_core.evaluation.frechet import frechet_distance, gaussian, normalize
from dance_core.evaluation.geometric import DIM, geometric_features
from dance_core.evaluation.kinetic import kinetic_features, kinetic_features_array
from dance_core.evaluation.metrics import (
    BailandoBAS,
    BeatCoverage,
    BeatOffset,
    FactBAS,
    FeatureDiversity,
    FeatureFID,
    FrechetPose,
    Freezing,
    PhysicalFootContact,
)
from dance_core.motion.skeletons import dance24
from dance_core.protocols import JointClip, Metric

REST = dance24().rest_positions()


def dancer(seed: int, seconds: float = 6.0, fps: float = 60.0, bpm: float = 120.0) -> JointClip:
    """An SMPL-24 body bouncing on the beat with random arm and leg swings (Y up, metres)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fps)) / fps
    f = bpm / 60.0
    rest = REST - REST[:, 1].min()
    amp = rng.normal(0, 0.08, size=(24, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(24, 3))
    p = rest[None] + amp[None] * np.sin(2 * np.pi * f * t[:, None, None] / 2 + phase[None])
    p[:, :, 1] += 0.05 * np.cos(2 * np.pi * f * t)[:, None]  # bounce: lowest on each beat
    p[:, :, 0] += 0.2 * np.sin(2 * np.pi * 0.1 * t + seed)[:, None]
    return JointClip(f"d{seed}", p, fps, music_beats=np.arange(0, seconds, 1 / f))


def oracle_kinetic(p: np.ndarray, frame_time: float, window: int, bug: bool) -> np.ndarray:
    """A literal per-frame loop over the AIST++ kinetic feature definition (the test's oracle)."""
    t, j = p.shape[:2]
    out = []
    for joint in range(j):
        kh = kv = ee = 0.0
        for i in range(1, t):
            v = np.zeros(3)
            n = 0
            for k in range(i - window, i + window + 1):
                if k - 1 < 0 or k >= t:
                    continue
                v += p[k, joint] - p[k - 1, joint]
                n += 1
            v /= n * frame_time
            kh += v[0] ** 2 + v[2] ** 2
            kv += v[1] ** 2
            a = np.zeros(3)
            n = 0
            for k in range(i - window, i + window + 1):
                if k - 1 < 0 or k + 1 >= t:
                    continue
                v2 = (p[k + 1, joint] - p[k, joint]) / frame_time
                v1 = p[k, joint] - p[k - 1, joint] / frame_time if bug else (p[k, joint] - p[k - 1, joint]) / frame_time
                a += (v2 - v1) / frame_time
                n += 1
            ee += np.linalg.norm(a / n)
        out += [kh / (t - 1), kv / (t - 1), ee / (t - 1)]
    return np.array(out)


def test_kinetic_features_match_a_literal_loop_in_both_modes():
    p = dancer(1, seconds=0.5).positions[:, :5]
    np.testing.assert_allclose(kinetic_features_array(p, 60.0), oracle_kinetic(p, 1 / 60, 2, False), rtol=1e-9)
    np.testing.assert_allclose(
        kinetic_features_array(p, 60.0, compat=True), oracle_kinetic(p, 1 / 60, 2, True), rtol=1e-9
    )


def test_compat_and_corrected_kinetic_features_differ_exactly_in_energy_expenditure():
    clip = dancer(2)
    fixed, compat = kinetic_features(clip).reshape(24, 3), kinetic_features(clip, compat=True).reshape(24, 3)
    assert kinetic_features(clip).shape == (72,)
    np.testing.assert_allclose(fixed[:, :2], compat[:, :2], rtol=1e-12)  # kinetic energies agree
    assert np.all(np.abs(fixed[:, 2] - compat[:, 2]) > 1e-3 * np.abs(fixed[:, 2]))  # the bug
    # the bug makes the compat expenditure depend on absolute position; the corrected one does not
    moved = JointClip("m", clip.positions + np.array([0.0, 0.5, 0.0]), clip.fps)
    np.testing.assert_allclose(kinetic_features(moved), kinetic_features(clip), rtol=1e-9)


def test_kinetic_features_are_rate_independent_in_seconds():
    hi = dancer(3, fps=60.0)
    lo = JointClip("lo", hi.positions[::3], 20.0)
    a, b = kinetic_features(hi).reshape(24, 3), kinetic_features(lo).reshape(24, 3)
    np.testing.assert_allclose(b[:, :2], a[:, :2], rtol=0.25)  # same speeds (a wider window smooths a bit)


def test_geometric_features_are_fractions_and_compat_doubles_speeds():
    clip = dancer(4)
    g = geometric_features(clip)
    assert g.shape == (DIM,) == (32,) and np.all((g >= 0) & (g <= 1))
    # a frozen body: no velocity predicate fires
    frozen = JointClip("f", np.repeat(clip.positions[:1], 100, axis=0), 60.0)
    fast_cols = [12, 13, 21, 22, 31]
    assert np.all(geometric_features(frozen)[fast_cols] == 0)
    # compat's 1/120 s step doubles speeds: a root moving at 0.4 HL... per second is "fast" only in compat
    from dance_core.evaluation.geometric import HL

    p = np.repeat(clip.positions[:1], 60, axis=0).copy()
    p[:, :, 2] += (2.3 * HL * 0.75) * np.arange(60)[:, None] / 60.0  # 0.75 x the threshold speed
    slide = JointClip("s", p, 60.0)
    assert geometric_features(slide)[31] == 0.0 and geometric_features(slide, compat=True)[31] == 1.0


def test_geometric_features_need_smpl_joints():
    with pytest.raises(DataError, match="24 SMPL joints"):
        geometric_features(JointClip("six", np.zeros((10, 6, 3)), 20.0))


def test_frechet_distance_known_values():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(50, 4))
    assert frechet_distance(*gaussian(x, "t"), *gaussian(x, "t")) == pytest.approx(0.0, abs=1e-9)
    # 1-D: (mu1 - mu2)^2 + (s1 - s2)^2
    assert frechet_distance(np.array([1.0]), np.array([[4.0]]), np.array([0.0]), np.array([[1.0]])) == pytest.approx(
        2.0
    )
    # rank-deficient covariances stay real and finite
    c = np.zeros((3, 3))
    c[0, 0] = 1.0
    assert frechet_distance(np.zeros(3), c, np.zeros(3), np.eye(3)) == pytest.approx(2.0)


def test_identical_sets_give_zero_fid_and_shifted_sets_do_not():
    clips = [dancer(s) for s in range(5)]
    for kind in ("kinetic", "geometric"):
        assert FeatureFID(kind)(clips, clips).values[f"FID_{kind[0]}"] == pytest.approx(0.0, abs=1e-6)
        assert FeatureFID(kind, compat=True)(clips, clips).values[f"FID_{kind[0]}"] == pytest.approx(0.0, abs=1e-6)
    lazy = [JointClip(c.name, c.positions[:1] + 0.3 * (c.positions - c.positions[:1]), c.fps) for c in clips]
    assert FeatureFID("kinetic")(lazy, clips).values["FID_k"] > 1.0
    for span in (1, 3):
        metric = FrechetPose(span)
        assert metric(clips, clips).values[metric.value] == pytest.approx(0.0, abs=1e-6)
        assert metric(lazy, clips).values[metric.value] > 1e-3


def test_normalization_and_diversity():
    ref = np.array([[0.0, 5.0], [2.0, 5.0]])
    r, g = normalize(ref, np.array([[1.0, 6.0]]))
    np.testing.assert_allclose(r, [[-1, 0], [1, 0]])
    np.testing.assert_allclose(g, [[0, 1]])  # the constant column is only centred
    clips = [dancer(s) for s in range(4)]
    same = [clips[0]] * 3
    assert FeatureDiversity("kinetic")(same, clips).values["Div_k"] == pytest.approx(0.0, abs=1e-9)
    assert FeatureDiversity("kinetic")(clips, clips).values["Div_k"] > 1.0


def test_bailando_bas_known_answers():
    music = np.arange(0.5, 5.0, 0.5)
    assert B.bailando_score(music, music) == pytest.approx(1.0)
    sigma = 3 / 60
    assert B.bailando_score(music, music + sigma) == pytest.approx(math.exp(-0.5))
    assert B.bailando_score(music, np.zeros(0)) == 0.0
    # FACT averages over motion beats: one extra motion beat far away halves nothing for Bailando
    motion = np.concatenate([music, [10.0]])
    assert B.bailando_score(music, motion) == pytest.approx(1.0)
    assert B.fact_score(music, motion) == pytest.approx(len(music) / len(motion))


def test_bas_metrics_on_motion_whose_speed_minima_sit_on_the_beats():
    fps, beat = 60.0, 0.5
    t = np.arange(int(6 * fps)) / fps
    # joint moves along x with speed |sin(pi t / beat)|: speed minima exactly at multiples of the beat
    # (the displacement from frame i to i+1 is the speed of frame i)
    x = np.concatenate([[0.0], np.cumsum(np.abs(np.sin(np.pi * t[:-1] / beat)))]) / fps
    p = np.zeros((len(t), 2, 3))
    p[:, :, 0] = x[:, None]
    music = np.arange(beat, 5.6, beat)
    clip = JointClip("on", p, fps, music_beats=music)
    assert BailandoBAS()([clip]).values["BAS_bailando"] == pytest.approx(1.0, abs=1e-9)
    # FACT assigns the displacement from frame i-1 to i to frame i: its beats come one frame later
    assert FactBAS()([clip]).values["BAS_fact"] == pytest.approx(math.exp(-1 / 18), abs=1e-9)
    late = JointClip("late", np.concatenate([np.repeat(p[:1], 3, axis=0), p])[: len(p)], fps, music_beats=music)
    assert BailandoBAS()([late]).values["BAS_bailando"] == pytest.approx(math.exp(-0.5), abs=1e-6)


def test_frozen_clip_has_full_pff_and_auc():
    frozen = JointClip("still", np.zeros((200, 24, 3)), 20.0)
    r = Freezing()([frozen])
    assert r.values["PFF"] == pytest.approx(100.0) and r.values["AUC_f"] == pytest.approx(100.0)
    moving = dancer(5)
    assert Freezing()([moving]).values["PFF"] == 0.0
    # a 4 s pause inside a 10 s dance: 40% frozen; a 2 s pause is not a freeze
    p = dancer(6, seconds=10, fps=20).positions.copy()
    p[60:140] = p[60]
    assert Freezing()([JointClip("pause", p, 20.0)]).values["PFF"] == pytest.approx(100 * 79 / 200, abs=1.0)
    q = dancer(6, seconds=10, fps=20).positions.copy()
    q[60:100] = q[60]
    assert Freezing()([JointClip("short", q, 20.0)]).values["PFF"] == 0.0


def test_beat_offsets_and_coverage():
    fps, period = 60.0, 0.5
    t = np.arange(int(6 * fps)) / fps
    p = np.zeros((len(t), 1, 3))
    p[:, 0, 1] = np.cos(2 * np.pi * (t - 0.375) / period)  # fastest downward motion at 0.5 k
    music = np.arange(0.5, 5.6, period)
    r = BeatOffset()([JointClip("h", p, fps, music_beats=music)])
    assert r.values["beat_offset_mean"] == pytest.approx(0.0, abs=1 / fps)
    shifted = BeatOffset()([JointClip("h", p, fps, music_beats=music + 0.1)])
    assert shifted.values["beat_offset_mean"] == pytest.approx(0.1, abs=1 / fps)
    cov, hit = B.coverage_and_hit_rate(np.array([1.0, 2.0, 3.0, 4.0]), np.array([1.02, 3.5]), 0.1)
    assert cov == pytest.approx(0.5) and hit == pytest.approx(0.5)
    clip = dancer(7)
    r = BeatCoverage()([clip])
    assert 0 <= r.values["beat_hit_rate"] <= 100 and r.values["beat_coverage"] > 0


def test_pfc_zero_for_planted_feet_and_positive_for_sliding_ones():
    clip = dancer(8)
    p = clip.positions.copy()
    p[:, [7, 8, 10, 11]] = p[:1, [7, 8, 10, 11]]  # feet planted, body bouncing
    assert PhysicalFootContact()([JointClip("planted", p, 60.0)]).values["PFC"] == pytest.approx(0.0)
    assert PhysicalFootContact()([clip]).values["PFC"] > 0.0
    still = PhysicalFootContact()([JointClip("still", np.zeros((30, 24, 3)), 60.0)])
    assert still.values["PFC"] == 0.0 and "never accelerates" in still.notes[0]


def test_guards_have_clear_messages():
    clips = [dancer(s) for s in range(3)]
    with pytest.raises(DataError, match="at least 2 reference"):
        FeatureFID("kinetic")(clips, clips[:1])
    with pytest.raises(DataError, match="needs at least 3 frames"):
        FeatureFID("kinetic")([JointClip("tiny", np.zeros((2, 24, 3)), 60.0)] * 2, clips)
    with pytest.raises(DataError, match="needs music beats"):
        BailandoBAS()([JointClip("x", clips[0].positions, 60.0)])
    no_beats = JointClip("nb", clips[0].positions, 60.0, music_beats=np.array([100.0]))
    with pytest.raises(DataError, match="no music beat within"):
        FactBAS()([no_beats])
    constant = JointClip("c", np.zeros((120, 24, 3)), 60.0, music_beats=np.array([0.5, 1.0]))
    r = BailandoBAS()([constant])
    assert r.values["BAS_bailando"] == 0.0 and "no motion beat" in r.notes[0]
    with pytest.raises(DataError, match="no clip has kinematic beats"):
        BeatOffset()([constant])
    with pytest.raises(DataError, match="shorter than"):
        Freezing()([JointClip("short", np.zeros((20, 24, 3)), 20.0)])
    with pytest.raises(DataError, match="NaN"):
        Freezing()([JointClip("nan", np.full((100, 24, 3), np.nan), 20.0)])
    six = JointClip("six", np.zeros((50, 6, 3)), 60.0)
    with pytest.raises(DataError, match="different joint counts"):
        FrechetPose(3)(clips, [six])
    with pytest.raises(DataError, match="different joint counts"):
        FeatureFID("kinetic")(clips, [six, six])
    with pytest.raises(DataError, match="different joint counts"):
        FeatureDiversity("kinetic")([*clips, six])
    with pytest.raises(DataError, match="ankle and toe"):
        PhysicalFootContact()([JointClip("six", np.zeros((50, 6, 3)), 60.0)])


@pytest.mark.parametrize("case", ["constant", "short", "no-beats"])
def test_every_registered_metric_gives_a_finite_value_or_a_clear_error(case):
    from dance_core.evaluation.report import build_metric
    from dance_core.registry import get_registry

    registry = get_registry()
    reference = [dancer(s, seconds=5.0, fps=20.0) for s in range(3)]
    frames = 2 if case == "short" else 100
    beats = np.zeros(0) if case == "no-beats" else np.arange(0.5, 4.5, 0.5)
    rest = reference[0].positions[:1]
    generated = [JointClip(f"{case}{k}", np.repeat(rest, frames, axis=0), 20.0, music_beats=beats) for k in range(2)]
    for name in registry.names("metric"):
        metric = build_metric(name, registry)
        assert isinstance(metric, Metric) and set(metric.needs) <= {"reference", "music"}
        try:
            result = metric(generated, reference)
        except DataError as exc:
            assert f"{case}0" in str(exc) or "no clip" in str(exc) or "every clip" in str(exc), (name, str(exc))
            assert "\n" not in str(exc)
            continue
        assert result.values and all(np.isfinite(v) for v in result.values.values()), (name, result.values)


def test_tempogram_peaks_at_the_pulse_tempo():
    from dance_core.evaluation.tempogram import impulses, tempogram

    fps = 50.0
    pulse = impulses(np.arange(0.2, 20.0, 0.5), int(20 * fps), fps)  # 120 bpm
    tg, bpm, times = tempogram(pulse, fps, window_seconds=6.0)
    assert times[0] == pytest.approx(0.0) and times[-1] == pytest.approx(20.0, abs=0.5)
    middle = tg[:, len(times) // 2]
    # the strongest tempo between 80 and 160 bpm is the pulse (its halves and doubles come next)
    band = (bpm > 80) & (bpm < 160)
    assert bpm[band][np.argmax(middle[band])] == pytest.approx(120.0, rel=0.03)
