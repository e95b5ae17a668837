"""dance_audio.dbn decodes as madmom 0.16.1's DBNDownBeatTrackingProcessor (compared where madmom is installed)."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest

from dance_audio.dbn import DBNDownBeatTracker, log_emissions, tempo_periods
from dance_audio.madmom_compat import madmom_available

needs_madmom = pytest.mark.skipif(not madmom_available(), reason="the madmom extra is not installed")


@pytest.fixture(scope="module")
def madmom_dbn():
    """madmom's processor class (with the compatibility fixes applied)."""
    if not madmom_available():
        pytest.skip("the madmom extra is not installed")
    from dance_audio.madmom_compat import import_madmom

    import_madmom()
    from madmom.features.downbeats import DBNDownBeatTrackingProcessor

    return DBNDownBeatTrackingProcessor


@pytest.fixture(scope="module")
def real_activations(sample, audio_dir, registry):
    """The ported RNN's activations of the two real songs, computed once for this module."""
    if not madmom_available():
        pytest.skip("the port reads madmom's installed weights")
    from dance_audio.downbeat import activations
    from dance_core.data.features import load_audio

    vibe = load_audio(audio_dir / "vibe_ace.ogg", registry)
    return {"sample": activations(sample), "vibe_ace": activations(vibe)}


def run_both(madmom_cls, act, **kwargs):
    """(ours, madmom's) results for the same arguments at 100 fps."""
    ours = DBNDownBeatTracker(fps=100, **kwargs)(act)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        theirs = np.asarray(madmom_cls(fps=100, **kwargs)(act), dtype=np.float64).reshape(-1, 2)
    return ours, theirs


def assert_same(ours, theirs):
    assert ours.shape == theirs.shape
    np.testing.assert_allclose(ours[:, 0], theirs[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(ours[:, 1], theirs[:, 1])


CASES = [
    dict(beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0),  # beats.py's defaults
    dict(beats_per_bar=[4], min_bpm=55.0, max_bpm=160.0),
    dict(beats_per_bar=[3, 4], min_bpm=90.0, max_bpm=210.0),
    dict(beats_per_bar=[2, 3, 4], min_bpm=[60.0, 55.0, 70.0], max_bpm=180.0, num_tempi=[40, 60, 80]),
    dict(beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0, correct=False),
    dict(beats_per_bar=[4], min_bpm=55.0, max_bpm=160.0, threshold=0),
    dict(beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0, transition_lambda=30, observation_lambda=8),
]


@pytest.mark.parametrize("song", ["sample", "vibe_ace"])
@pytest.mark.parametrize("kwargs", CASES, ids=lambda k: "-".join(f"{v}" for v in k.values()))
def test_same_beats_as_madmom_on_real_music(madmom_dbn, real_activations, song, kwargs):
    ours, theirs = run_both(madmom_dbn, real_activations[song], **kwargs)
    assert len(ours) >= 3  # sample.wav is 2.8 s long
    assert_same(ours, theirs)


def test_same_viterbi_paths_and_log_probabilities_as_madmom(madmom_dbn, real_activations):
    act = real_activations["vibe_ace"]
    rows = np.nonzero(act >= 0.05)[0]
    act = act[rows.min() : rows.max() + 1]
    theirs = madmom_dbn(beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0, fps=100)
    ours = DBNDownBeatTracker([3, 4], 55.0, 160.0, fps=100)
    emit = log_emissions(act, ours.observation_lambda)
    for model, hmm in zip(ours.models, theirs.hmms, strict=True):
        st, om = hmm.transition_model.state_space, hmm.observation_model
        np.testing.assert_array_equal(model.periods, st.state_intervals[st.first_states[0]])
        path, log_prob = hmm.viterbi(act)
        ours_log_prob, beat_index, on_beat = model.viterbi(emit)
        assert ours_log_prob == log_prob  # bit for bit
        np.testing.assert_array_equal(beat_index, st.state_positions[path].astype(int))
        np.testing.assert_array_equal(on_beat, om.pointers[path] >= 1)


@pytest.mark.parametrize(
    ("low", "high", "num"), [(37.5, 109.1, 60), (28.6, 66.7, 60), (30.0, 40.0, 60), (20, 90, None)]
)
def test_tempo_periods_match_madmom(madmom_dbn, low, high, num):
    from madmom.features.beats_hmm import BeatStateSpace

    np.testing.assert_array_equal(tempo_periods(low, high, num), BeatStateSpace(low, high, num).intervals)


def degenerate_inputs():
    rng = np.random.default_rng(1)
    short = np.full((40, 2), 0.01, dtype=np.float32)
    short[[5, 25], 0], short[15, 1] = 0.8, 0.9
    single = np.zeros((10, 2), dtype=np.float32)
    single[4, 0] = 0.5
    return {
        "all-zero": np.zeros((500, 2), dtype=np.float32),
        "below-threshold": (0.049 * rng.random((500, 2))).astype(np.float32),
        "empty": np.zeros((0, 2), dtype=np.float32),
        "only-frame-0-above": np.r_[[[0.9, 0.0]], np.zeros((99, 2))].astype(np.float32),
        "short-clip": short,
        "one-frame-above": single,
        "noise": (0.3 * rng.random((300, 2))).astype(np.float32),
    }


@pytest.mark.parametrize("name", list(degenerate_inputs()))
def test_degenerate_input_like_madmom(madmom_dbn, name):
    act = degenerate_inputs()[name]
    ours, theirs = run_both(madmom_dbn, act, beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0)
    assert_same(ours, theirs)
    if name in ("all-zero", "below-threshold", "empty", "only-frame-0-above"):
        assert ours.shape == (0, 2)


def test_no_possible_path_gives_no_beats_where_madmom_raises(madmom_dbn):
    # beat + downbeat above 1 makes the non-beat probability negative (log: NaN), so every frame
    # must be a beat-range frame: no path exists. madmom decodes an empty path and then fails on
    # it; we return no beats.
    act = np.full((200, 2), 0.6, dtype=np.float32)
    assert DBNDownBeatTracker([3, 4], 55.0, 160.0, fps=100)(act).shape == (0, 2)
    with warnings.catch_warnings(), pytest.raises(IndexError):
        warnings.simplefilter("ignore", RuntimeWarning)
        madmom_dbn(beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0, fps=100)(act)


def test_tracks_a_synthetic_activation_without_madmom():
    act = np.full((1000, 2), 0.01, dtype=np.float32)
    beat_frames = np.arange(30, 1000, 50)  # 120 BPM at 100 fps
    for k, f in enumerate(beat_frames):
        act[f, 1 if k % 3 == 0 else 0] = 0.9  # a bar of three, starting on the first beat
    result = DBNDownBeatTracker([3, 4], 55.0, 160.0, fps=100)(act)
    np.testing.assert_allclose(result[:, 0], beat_frames / 100)
    np.testing.assert_array_equal(result[:, 1], np.arange(len(beat_frames)) % 3 + 1)


def test_rejects_bad_input():
    tracker = DBNDownBeatTracker([4], fps=100)
    with pytest.raises(ValueError, match="finite"):
        tracker(np.array([[0.5, np.nan]] * 10))
    with pytest.raises(ValueError, match="frames, 2"):
        tracker(np.zeros(10))
    with pytest.raises(ValueError, match="min_bpm"):
        DBNDownBeatTracker([3, 4], min_bpm=[50.0, 60.0, 70.0], fps=100)


@needs_madmom
def test_track_madmom_does_not_import_madmom(audio_dir):
    code = (
        "import sys; from dance_audio.beats import track_madmom; from dance_core.data.features import load_audio;"
        "from dance_core.registry import get_registry;"
        f"a = load_audio({str(audio_dir / 'sample.wav')!r}, get_registry());"
        "b = track_madmom(a, [3, 4], 55.0, 160.0); assert len(b.times) >= 4, b;"
        "assert not [m for m in sys.modules if m.split('.')[0] == 'madmom'], 'madmom imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)


@pytest.mark.parametrize(("start", "stop"), [(0, 30), (0, 150), (3000, 3012), (6100, 6146)])
def test_short_clips_of_real_music_like_madmom(madmom_dbn, real_activations, start, stop):
    act = real_activations["vibe_ace"][start:stop]
    ours, theirs = run_both(madmom_dbn, act, beats_per_bar=[3, 4], min_bpm=55.0, max_bpm=160.0)
    assert_same(ours, theirs)


def test_track_madmom_without_madmom_gives_the_install_hint(sample, monkeypatch):
    import dance_audio.madmom_compat as compat
    from dance_audio.beats import track_madmom
    from dance_core.errors import PluginError

    monkeypatch.setattr(compat, "madmom_available", lambda: False)
    with pytest.raises(PluginError, match="pip install"):
        track_madmom(sample, [3, 4], 55.0, 160.0)
