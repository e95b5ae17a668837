"""Meter detection: waltzes get bars of three beats, everything else four; the tracker's downbeats follow."""

from __future__ import annotations

import numpy as np
from dance_audio.beats import track_beats
from dance_audio.meter import beat_patterns, detect_meter, lag_similarity, meter_scores
from dance_core import Audio
from dance_core.synth.music import synthesize

RATE = 22050


def test_patterns_repeating_every_three_beats_score_three():
    rng = np.random.default_rng(0)
    fps, period = 100.0, 0.5
    times = np.arange(0.0, 40.0, period)
    bar = [rng.random(12) + 0.1 for _ in range(3)]  # three different beats, repeated bar after bar
    env = np.zeros(int(40.0 * fps) + 1)
    for k, t in enumerate(times[:-1]):
        at = int(round(t * fps))
        env[at : at + 50] = np.repeat(bar[k % 3], 5)[:50] * (1 + 0.05 * rng.standard_normal(50))
    patterns = beat_patterns(env, times, fps)
    assert patterns.shape == (len(times) - 1, 12)
    assert lag_similarity(patterns, 3) > 0.9 and lag_similarity(patterns, 4) < 0.5
    scores = meter_scores(env, times, fps, (3, 4))
    assert scores[3] > scores[4] + 0.3 and detect_meter(env, times, fps) == 3
    assert detect_meter(env, times, fps, (4,)) == 4  # a single candidate is taken as given


def test_a_tie_or_a_short_song_counts_in_four():
    fps, times = 100.0, np.arange(0.0, 20.0, 0.5)
    flat = np.ones(int(20 * fps) + 1)
    assert detect_meter(flat, times, fps) == 4
    assert detect_meter(flat, times[:3], fps) == 4


def test_synthesized_waltzes_and_four_four_songs():
    """Every song's meter right; the bars' first beats (chosen by onset strength) right on most songs."""
    phase_right = 0
    for meter, bpm, seed in ((3, 84, 1), (3, 110, 2), (3, 126, 3), (4, 98, 4), (4, 120, 5), (4, 140, 6)):
        song = synthesize(30.0, float(bpm), RATE, np.random.default_rng(seed), beats_per_bar=meter)
        beats = track_beats(Audio(song.audio, RATE), "flux")
        assert abs(60 / np.median(np.diff(beats.times)) - bpm) < 0.1 * bpm  # the tracker hears the tempo
        assert beats.positions.max() == meter, (meter, bpm)
        assert (np.diff(np.flatnonzero(beats.positions == 1)) == meter).all()
        near = np.abs(beats.downbeats[:, None] - np.asarray(song.downbeats)[None]).min(1)
        phase_right += np.mean(near < 0.07) > 0.8
    assert phase_right >= 5
