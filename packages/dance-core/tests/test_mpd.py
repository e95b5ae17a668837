"""TM2D's Motion Prediction Distance with the motion-matching predictor: the body frame, evaluation
points, and sanity on the synthetic dancer (real dances continue the way other real dances do;
a jump cut, a freeze or noise does not)."""

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.evaluation.canon import canonicalize, heading, hip_indices
from dance_core.evaluation.mpd import MatchingPredictor, MotionPredictionDistance
from dance_core.protocols import JointClip
from dance_core.synth.synthetic_dance import make_clip

FPS = 30.0
TIMES = (3.3, 7.1, 11.6)  # evaluation points (s) of the sanity tests


def smpl_clip(index: int, seconds: float = 16.0) -> JointClip:
    """One synthetic dance (SMPL-24 joints, metres, Y up) with its move labels as text spans."""
    src = make_clip(index, seed=5, seconds=seconds, bpm=(90.0, 130.0), rate=4000, fps=FPS)
    motion = src.motion.skeleton_motion
    texts = [(t.start, t.end, t.text) for t in src.texts]
    return JointClip(src.name, motion.positions(), FPS, list(motion.skeleton.names), meta={"texts": texts})


@pytest.fixture(scope="module")
def dances():
    return [smpl_clip(i) for i in range(12)]


def yawed(p: np.ndarray, angle: float, shift: tuple[float, float]) -> np.ndarray:
    """Positions turned by ``angle`` about Y and moved by ``shift`` on the floor."""
    c, s = np.cos(angle), np.sin(angle)
    out = p.copy()
    out[..., 0] = c * p[..., 0] + s * p[..., 2] + shift[0]
    out[..., 2] = -s * p[..., 0] + c * p[..., 2] + shift[1]
    return out


def test_canonical_frame_faces_plus_z_over_the_origin_wherever_the_dance_is(dances):
    clip = dances[0]
    left, right = hip_indices(clip)
    assert (left, right) == (1, 2)
    window = clip.positions[100:155]
    a = canonicalize(window, 24, left, right)
    root, across = a[24, 0], a[24, left] - a[24, right]
    assert root[[0, 2]] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert across[0] > 0 and across[2] == pytest.approx(0.0, abs=1e-12)  # left hip on +X: facing +Z
    np.testing.assert_allclose(heading(a[24], left, right), [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(a[..., 1], window[..., 1])  # heights are kept
    for angle, shift in ((0.7, (3.0, -2.0)), (-2.9, (-0.5, 8.0)), (np.pi, (0.0, 0.0))):
        np.testing.assert_allclose(canonicalize(yawed(window, angle, shift), 24, left, right), a, atol=1e-9)
    batch = canonicalize(np.stack([window, yawed(window, 1.0, (1.0, 1.0))]), 24, left, right)
    np.testing.assert_allclose(batch[1], batch[0], atol=1e-9)


def test_hips_by_name_or_smpl_order_else_a_clear_error():
    named = JointClip("n", np.zeros((5, 3, 3)), 30.0, ["Hips", "LeftUpLeg", "RightUpLeg"])
    assert hip_indices(named) == (1, 2)
    assert hip_indices(JointClip("s", np.zeros((5, 24, 3)), 30.0)) == (1, 2)
    assert hip_indices(named, ["RightUpLeg", "Hips"]) == (2, 0)
    with pytest.raises(DataError, match="6 joints"):
        hip_indices(JointClip("six", np.zeros((5, 6, 3)), 30.0))
    with pytest.raises(DataError, match="no joint named lhip"):
        hip_indices(named, ["lhip", "Hips"])


def test_a_dance_in_the_reference_predicts_itself_exactly_unless_left_out(dances):
    ref = dances[:4]
    exact = MotionPredictionDistance(exclude_same_name=False)(ref, ref)
    assert all(v == pytest.approx(0.0, abs=1e-9) for k, v in exact.values.items() if "speed" not in k)
    left_out = MotionPredictionDistance()(ref, ref)
    assert all(v > 0.005 for v in left_out.values.values())
    # the predictor proposes k futures, nearest first
    predictor = MatchingPredictor(ref, 25, 30, k=3)
    past = canonicalize(ref[0].positions[200:225], 24, 1, 2)[None]
    futures, valid = predictor.predict(past, exclude=[None])
    assert futures.shape == (1, 3, 30, 24, 3) and valid.all()
    np.testing.assert_allclose(futures[0, 0], canonicalize(ref[0].positions[200:255], 24, 1, 2)[25:], atol=1e-9)
    # leave-one-out: a clip never matches itself, and slots without a candidate stay empty
    tiny = JointClip("tiny", ref[1].positions[:56], FPS, ref[1].joints)  # two windows
    predictor = MatchingPredictor([tiny, ref[0]], 25, 30, k=4)
    _, clips, starts = predictor.nearest(np.concatenate([past, past]), exclude=[ref[0].name, None])
    assert clips[0].tolist() == [0, 0, -1, -1] and sorted(starts[0, :2].tolist()) == [0, 1]
    assert clips[1, 0] == 1 and starts[1, 0] == 200  # not left out: itself first
    with pytest.raises(DataError, match="every reference clip is excluded"):
        MotionPredictionDistance()(ref[:1], ref[:1])


def variants(dances: list[JointClip], kind: str) -> list[JointClip]:
    """Every dance scored once per time in TIMES, its motion from there on changed by ``kind``."""
    out = []
    for i, clip in enumerate(dances):
        other = dances[(i + 1) % len(dances)].positions
        for k, t in enumerate(TIMES):
            t1, p = int(round(t * FPS)), clip.positions.copy()
            if kind == "jump cut":  # another dance from t1 on, where that dance was
                p[t1:] = other[t1 : len(p)]
            elif kind == "aligned cut":  # the same, moved on the floor to where this dance was
                p[t1:] = other[t1 : len(p)] + (p[t1 - 1, 0] - other[t1, 0]) * np.array([1.0, 0.0, 1.0])
            elif kind == "frozen":
                p[t1:] = p[t1 - 1]
            elif kind == "noise":
                p[t1:] += np.random.default_rng([i, k]).normal(0.0, 0.03, p[t1:].shape)
            out.append(JointClip(clip.name, p, FPS, clip.joints, meta={"texts": [(t, t + 1.0, "a person jumps")]}))
    return out


def test_real_continuations_score_low_and_cuts_freezes_and_noise_do_not(dances):
    mpd = MotionPredictionDistance()
    scores = {
        kind: mpd(variants(dances, kind), dances).values
        for kind in ("ground truth", "jump cut", "aligned cut", "frozen", "noise")
    }
    for kind, values in scores.items():
        print(f"{kind:12s}", "  ".join(f"{k} {v:.4f}" for k, v in values.items()))
    gt = scores["ground truth"]
    assert gt["mpd_10"] < gt["mpd_20"] < gt["mpd_30"] < 0.08  # metres; the error grows with the horizon
    for ft in ("mpd_10", "mpd_20", "mpd_30"):
        assert scores["jump cut"][ft] > 2.5 * gt[ft] and scores["aligned cut"][ft] > 2.5 * gt[ft]
        assert scores["noise"][ft] > 1.3 * gt[ft]
    assert scores["frozen"]["mpd_10"] > 2 * gt["mpd_10"] and scores["frozen"]["mpd_20"] > 1.5 * gt["mpd_20"]
    assert scores["frozen"]["mpd_30"] > gt["mpd_30"]
    # the energy beside it: the real continuations move like the reference, the frozen ones much less
    assert gt["mpd_speed"] == pytest.approx(gt["mpd_speed_reference"], rel=0.5)
    assert scores["frozen"]["mpd_speed"] < 0.7 * gt["mpd_speed"]
    assert len({v["mpd_speed_reference"] for v in scores.values()}) == 1


def test_the_energy_beside_mpd_is_the_mean_joint_speed_of_the_scored_frames(dances):
    pose = dances[0].positions[0]
    t = np.arange(len(dances[0].positions))[:, None, None] / FPS
    gliding = JointClip("glide", pose + t * np.array([0.5, 0.0, 0.0]), FPS, dances[0].joints)  # 0.5 m/s
    still = JointClip("still", np.broadcast_to(pose, dances[0].positions.shape).copy(), FPS, dances[0].joints)
    r = MotionPredictionDistance()([gliding, still], dances[1:4])
    assert r.per_clip["glide"]["mpd_speed"] == pytest.approx(0.5, rel=1e-6)
    assert r.per_clip["still"]["mpd_speed"] == 0.0
    assert r.values["mpd_speed"] == pytest.approx(0.25, rel=1e-6)  # both clips have 8 points
    assert r.values["mpd_speed_reference"] > 0.1


def test_points_at_text_starts_else_regularly_with_notes(dances):
    clip = dances[0]  # 16 s: 960 frames at the metric's 60 fps
    spans = [(0.0, 1.0, "a"), (0.2, 1.0, "b"), (5.0, 6.0, "c"), (15.9, 16.0, "d")]
    texted = JointClip("texted", clip.positions, FPS, clip.joints, meta={"texts": spans})
    plain = JointClip("plain", clip.positions, FPS, clip.joints)
    short = JointClip("short", clip.positions[:20], FPS, clip.joints)
    mpd = MotionPredictionDistance()
    r = mpd([texted, plain, short], dances[1:4])
    assert r.per_clip["texted"]["points"] == 1.0
    assert r.per_clip["plain"]["points"] == 8.0  # t1 = 25, 145, ..., 865 frames: every 2 s up to 930
    assert "short" not in r.per_clip
    assert any("texted: 3 of 4 text start(s)" in n for n in r.notes)
    assert any("short: 39 frames at 60 fps are fewer than the 55" in n for n in r.notes)
    assert any("9 point(s) in 2 clip(s) (1 at text starts, 8 at regular times)" in n for n in r.notes)
    assert set(r.values) == {"mpd_10", "mpd_20", "mpd_30", "mpd_speed", "mpd_speed_reference"}
    # the summary is the mean over all points
    mean = (r.per_clip["texted"]["mpd_20"] + 8 * r.per_clip["plain"]["mpd_20"]) / 9
    assert r.values["mpd_20"] == pytest.approx(mean)
    with pytest.raises(DataError, match="no clip has an evaluation point"):
        mpd([short], dances[1:4])
    with pytest.raises(DataError, match="at least 1 reference"):
        mpd([plain], [])
    with pytest.raises(DataError, match="must lie in 1..30"):
        MotionPredictionDistance(at=[10, 40])


def test_compose_writes_text_sidecars_that_evaluate_scores_at_text_starts(tmp_path):
    pytest.importorskip("dance_audio")
    from dance_core.compose import compose
    from dance_core.data.dataset_configs import SyntheticBeatsConfig
    from dance_core.data.files import read_texts
    from dance_core.data.synthetic_beats import SyntheticBeats, click_track
    from dance_core.evaluation.loading import load_clips
    from dance_core.evaluation.report import evaluate
    from dance_core.formats.wav import write_wav
    from dance_core.recipe import load_recipe
    from dance_core.recipe.schema import TextSpec
    from dance_core.registry import get_registry
    from dance_core.train import train

    (tmp_path / "vocab.txt").write_text("a\nperson\njumps\nclaps\n")
    sets = [
        "data.dataset.songs=2",
        "data.dataset.seconds=4",
        "training.steps=1",
        "training.batch_size=4",
        "training.val_every=1",
        "training.checkpoint_every=1",
        f"features.text=[{{plugin: word-tokens, vocab: {tmp_path / 'vocab.txt'}, max_words: 4}}]",
    ]
    ckpt = train(load_recipe("core-synthetic", sets), out=str(tmp_path / "run"), quiet=True).checkpoint
    write_wav(tmp_path / "song.wav", click_track(np.arange(0, 4, 0.5), 4.0, 16000, np.random.default_rng(0)), 16000)
    texts = [TextSpec.parse("2-3: a person  jumps").model_dump()]
    recipe = load_recipe("core-synthetic", [*sets, f"compose.texts={texts}"])
    [path] = compose(
        recipe, music=[str(tmp_path / "song.wav")], checkpoint=str(ckpt), out_dir=str(tmp_path / "out"), quiet=True
    )
    sidecar = path.with_name("song.texts")
    assert [(t.start, t.end, t.text) for t in read_texts(sidecar)] == [(2.0, 3.0, "a person jumps")]
    [generated] = load_clips(tmp_path / "out", get_registry())
    assert generated.meta["texts"] == [(2.0, 3.0, "a person jumps")]
    data = SyntheticBeats(SyntheticBeatsConfig(songs=3, seconds=6.0, sample_rate=8000), fps=20.0)
    names = [f"joint{j}" for j in range(6)]
    reference = [
        JointClip(c.name, c.motion.values.reshape(len(c.motion.values), 6, 3), 20.0, names) for c in data.clips()
    ]
    options = {"mpd": {"fps": 20.0, "hips": ["joint1", "joint2"]}}
    report = evaluate([generated], reference, ["mpd"], options=options)
    assert not report.skipped and np.isfinite(list(report.values().values())).all()
    assert any("1 point(s) in 1 clip(s) (1 at text starts)" in n for n in report.notes)
