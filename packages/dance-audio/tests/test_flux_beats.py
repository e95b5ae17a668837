"""The ``flux`` beat tracker: a bar-pointer HMM over beat phase and tempo on dance-audio's own
spectral flux. Synthetic material with known beats: clicks, kicks, hats."""

from __future__ import annotations

import numpy as np
import pytest

from dance_audio.beats import BeatFeatures, track_beats
from dance_audio.flux_beats import FPS, beat_activation, moving_max, moving_mean, onset_envelope, track_times
from dance_core import Audio
from dance_core.media import FeatureInputs

RATE = 22050


def ramp_times(start_bpm: float, end_bpm: float, seconds: float, first: float = 0.5) -> np.ndarray:
    """Beat times whose tempo moves linearly (per beat) from ``start_bpm`` to ``end_bpm``."""
    times, t = [], first
    n = int(seconds * (start_bpm + end_bpm) / 120)
    for k in range(n):
        times.append(t)
        t += 60.0 / (start_bpm + (end_bpm - start_bpm) * k / max(1, n - 1))
    return np.array([x for x in times if x < seconds - 0.3])


def drum(times, seconds: float, hz: float, decay: float, gain: float, rng) -> np.ndarray:
    """Decaying sine bursts (a kick at low ``hz``, a hat-like tick at high ``hz``) at ``times``."""
    y = np.zeros(int(seconds * RATE))
    n = int(0.2 * RATE)
    k = np.arange(n) / RATE
    burst = gain * np.sin(2 * np.pi * hz * k) * np.exp(-k / decay)
    for t in times:
        i = int(round(t * RATE))
        y[i : i + n] += burst[: len(y) - i]
    return y


def matched(detected: np.ndarray, truth: np.ndarray, window: float) -> tuple[int, float]:
    """How many true beats have a detection within ``window`` s, and the largest distance from a
    detection to its nearest true beat."""
    if len(detected) == 0:
        return 0, np.inf
    hits = sum(bool(np.min(np.abs(detected - t)) <= window) for t in truth)
    return hits, float(max(np.min(np.abs(truth - d)) for d in detected))


def test_moving_helpers_match_their_definitions():
    x = np.random.default_rng(3).standard_normal(257)
    for width in (1, 2, 5, 8, 33, 300):
        lo = np.arange(len(x)) - width // 2
        want_max = [x[max(0, a) : min(len(x), a + width)].max() for a in lo]
        want_mean = [x[max(0, a) : min(len(x), a + width)].mean() for a in lo]
        np.testing.assert_allclose(moving_max(x, width), want_max)
        np.testing.assert_allclose(moving_mean(x, width), want_mean)


def test_follows_a_tempo_ramp_from_90_to_110_bpm(make_clicks):
    truth = ramp_times(90.0, 110.0, 24.0)
    times, _ = track_times(make_clicks(truth, 24.0).samples, RATE)
    hits, worst = matched(times, truth, 0.05)
    assert worst <= 0.05  # every beat found lies on a click
    assert hits >= len(truth) - 2  # and every click but at most the first or last is found
    tempo = 60.0 / np.diff(times)
    assert tempo[:4].mean() < 95 and tempo[-4:].mean() > 105  # it followed the ramp


def test_a_single_global_tempo_cannot_follow_the_same_ramp(make_clicks):
    """The reason for the HMM: librosa's dynamic program, with one tempo, misses much of the ramp."""
    truth = ramp_times(90.0, 110.0, 24.0)
    audio = make_clicks(truth, 24.0)
    flux_hits, _ = matched(track_beats(audio, "flux").times, truth, 0.05)
    librosa_hits, _ = matched(track_beats(audio, "librosa").times, truth, 0.05)
    assert flux_hits > librosa_hits


def test_the_beat_is_on_the_kick_not_on_louder_off_beat_hats():
    """120 BPM: a kick on every beat, louder hats half-way between: beats on the kicks, at 120."""
    rng = np.random.default_rng(0)
    beats = 0.4 + np.arange(40) * 0.5
    y = drum(beats, 21.0, 60.0, 0.08, 0.6, rng) + drum(beats + 0.25, 21.0, 7000.0, 0.01, 0.9, rng)
    times, _ = track_times(y.astype(np.float32), RATE)
    hits, worst = matched(times, beats, 0.05)
    assert hits >= len(beats) - 2 and worst <= 0.05


def test_slow_kicks_with_hats_on_the_eighths_stay_at_the_kicks_level():
    """80 BPM kick and bass on the beats and hats on every 8th (160 per minute): the beat level is
    the kicks', not the double."""
    rng = np.random.default_rng(1)
    beats = 0.3 + np.arange(26) * 0.75
    eighths = 0.3 + np.arange(52) * 0.375
    y = drum(beats, 20.0, 55.0, 0.12, 0.7, rng) + drum(eighths, 20.0, 6000.0, 0.015, 0.5, rng)
    times, _ = track_times(y.astype(np.float32), RATE)
    assert 75 < 60.0 / np.median(np.diff(times)) < 85
    hits, worst = matched(times, beats, 0.05)
    assert hits >= len(beats) - 2 and worst <= 0.05


def test_deterministic(make_clicks):
    audio = make_clicks(ramp_times(100.0, 120.0, 12.0), 12.0)
    a, b = track_beats(audio, "flux"), track_beats(audio, "flux")
    np.testing.assert_array_equal(a.times, b.times)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert len(a.times) >= 15


@pytest.mark.parametrize("seconds", [0.0, 0.01, 0.3, 1.0, 10.0])
def test_silence_and_short_audio_give_no_beats(seconds):
    audio = Audio(np.zeros(int(seconds * RATE), dtype=np.float32), RATE)
    beats = track_beats(audio, "flux")
    assert beats.times.shape == (0,) and beats.positions.shape == (0,)
    n = audio.n_frames(30.0) if seconds else 1
    feats = BeatFeatures("flux", [3, 4], 55.0, 160.0).extract(FeatureInputs(n_frames=n, audio=audio), 30.0)
    assert feats.shape == (n, 6) and not feats[:, :2].any()  # no beat, no downbeat


def test_short_clicks_give_beats_on_the_clicks(make_clicks):
    clicks = np.array([0.2, 0.7, 1.2, 1.7])  # 2 s at 120 BPM
    times, _ = track_times(make_clicks(clicks, 2.0).samples, RATE)
    hits, worst = matched(times, clicks, 0.05)
    assert hits >= 3 and worst <= 0.05


def test_silence_around_music_gets_no_beats(make_clicks):
    clicks = 5.0 + np.arange(20) * 0.5
    audio = make_clicks(clicks, 20.0)
    times, _ = track_times(audio.samples, RATE)
    assert times.min() >= clicks[0] - 0.05 and times.max() <= clicks[-1] + 0.05


def test_activation_is_a_probability_cropped_to_the_onsets(make_clicks):
    env = onset_envelope(make_clicks(2.0 + np.arange(8) * 0.5, 8.0).samples, RATE)
    assert len(env) == 1 + int(8.0 * RATE) // 220
    p, first, end = beat_activation(env)
    assert len(p) == end - first and np.all((p > 0) & (p < 1))
    assert abs(first / FPS - 2.0) < 0.05 and abs(end / FPS - 5.5) < 0.1


def test_bad_tempo_range_is_one_clear_error(make_clicks):
    from dance_core import PluginError

    with pytest.raises(PluginError, match="tempo range"):
        track_beats(make_clicks([0.5], 2.0), "flux", min_bpm=120.0, max_bpm=100.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_numpy_decoder_finds_the_path_of_the_dbn_kernel(seed):
    """The flux tracker's NumPy Viterbi (no numba import) decodes the beat-only bar-pointer model
    exactly as dance_audio.dbn's compiled kernel, prior included."""
    import dataclasses

    from dance_audio.dbn import bar_model, log_emissions
    from dance_audio.flux_beats import OBSERVATION_LAMBDA, beat_viterbi, prior_transitions

    rng = np.random.default_rng(seed)
    frames = 1500
    period = rng.uniform(40, 80)
    p = 0.02 + 0.88 * np.exp(-0.5 * ((np.arange(frames) % period) / 2.0) ** 2) * rng.uniform(0.3, 1.0, frames)
    p = np.clip(p + 0.1 * rng.random(frames), 0.02, 0.9)
    model = bar_model(1, 60.0 * 100 / 160.0, 60.0 * 100 / 55.0, 60, 100.0, float(OBSERVATION_LAMBDA))
    log_trans, periods = prior_transitions(model.log_trans, model.periods, 100.0)
    ours = beat_viterbi(np.log(p), np.log((1 - p) / (OBSERVATION_LAMBDA - 1)), periods, model.on_beat[0], log_trans)
    emit = log_emissions(np.stack([np.zeros_like(p), p], axis=1), OBSERVATION_LAMBDA)
    _, _, kernel = dataclasses.replace(model, log_trans=log_trans).viterbi(emit)
    assert ours.sum() > 20
    np.testing.assert_array_equal(ours, kernel)


def test_the_default_tracker_starts_without_numba():
    """In a fresh process the flux tracker imports no numba (its start-up alone costs about a second
    on the 2-core CI machine, more than decoding a song) and nothing heavier."""
    import subprocess
    import sys

    script = (
        "import sys, numpy as np\n"
        "from dance_core import Audio\n"
        "from dance_audio.beats import track_beats\n"
        "y = np.zeros(22050 * 4, np.float32); y[::11025] = 1.0\n"
        "beats = track_beats(Audio(y, 22050))\n"
        "heavy = ('numba', 'torch', 'librosa', 'madmom', 'scipy.signal', 'scipy.ndimage', 'scipy.stats')\n"
        "print(len(beats.times), sorted(m for m in heavy if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout.split()
    assert int(out[0]) >= 4 and out[1:] == ["[]"]
