import time

import numpy as np
import pytest

from dance_core.synth.music import STYLES, swung, synthesize


def flux(song, n_fft=512, n_bands=24):
    """Spectral flux (mean positive dB rise over log-spaced bands) at 100 frames/s; entry i: time i / 100."""
    hop = song.rate / 100
    x = np.concatenate([np.zeros(n_fft // 2), song.audio.astype(float), np.zeros(n_fft)])
    idx = np.arange(n_fft)[None] + np.round(hop * np.arange(int((len(x) - n_fft) / hop)))[:, None].astype(int)
    power = np.abs(np.fft.rfft(x[idx] * np.hanning(n_fft), axis=1)) ** 2
    edges = np.unique(np.geomspace(2, n_fft // 2, n_bands + 1).astype(int))
    db = 10 * np.log10(1e-10 + np.add.reduceat(power, edges[:-1], axis=1))
    return np.concatenate([[0.0], np.maximum(0.0, np.diff(db, axis=0)).mean(axis=1)])


def near(env, times, width=0.04):
    """The largest value of ``env`` within ``width`` s of each time."""
    k = np.round(np.asarray(times) * 100).astype(int)
    w = int(width * 100)
    return np.array([env[max(0, i - w):i + w + 1].max() for i in k])


def beat_profile(song, env, bins=25):
    """Mean of ``env`` over the phase within the beat (0 at a beat, 1 at the next), in ``bins`` bins."""
    t = np.arange(len(env)) / 100
    k = np.searchsorted(song.beats, t) - 1
    inside = (k >= 0) & (k < len(song.beats) - 1)
    phase = (t[inside] - song.beats[k[inside]]) / np.diff(song.beats)[k[inside]]
    b = np.minimum(bins - 1, (phase * bins).astype(int))
    return np.bincount(b, env[inside], bins) / np.maximum(1, np.bincount(b, None, bins))


def test_same_seed_same_song():
    a, b = (synthesize(8.0, 100.0, 8000, np.random.default_rng(3)) for _ in range(2))
    np.testing.assert_array_equal(a.audio, b.audio)
    np.testing.assert_array_equal(a.beats, b.beats)
    assert (a.style, a.swing, a.drift, a.beats_per_bar) == (b.style, b.swing, b.drift, b.beats_per_bar)
    c = synthesize(8.0, 100.0, 8000, np.random.default_rng(4))
    assert len(c.audio) == len(a.audio) and not np.array_equal(a.audio, c.audio)


@pytest.mark.parametrize("bpm", [70.0, 120.0, 180.0])
def test_beats_cover_the_song_and_drift_within_the_bound(bpm):
    seconds, period = 30.0, 60.0 / bpm
    for seed in range(4):
        song = synthesize(seconds, bpm, 8000, np.random.default_rng(seed), drift=0.04 if seed < 2 else None)
        iv = np.diff(song.beats)
        assert song.audio.dtype == np.float32 and len(song.audio) == seconds * 8000
        assert 0 < song.beats[0] <= 0.5 * period + 1e-9 and song.beats[-1] < seconds
        assert song.beats[-1] > seconds - period * (1 + song.drift)
        assert 0 <= song.drift <= 0.04
        assert iv.min() >= period * (1 - song.drift) - 1e-6 and iv.max() <= period * (1 + song.drift) + 1e-6
        assert song.bpm == pytest.approx(bpm, rel=0.01)
        if seed < 2:
            assert iv.max() - iv.min() > 0.02 * period  # a drifting band: beats are not evenly spaced
        bars = [b for _, a, e in song.section_bars for b in range(a, e)]
        assert bars == list(range(int(np.ceil(len(song.beats) / song.beats_per_bar))))
        starts = song.downbeats[[a for _, a, _ in song.section_bars]]
        np.testing.assert_allclose([s for _, s, _ in song.sections], starts)


def test_three_four_songs_have_a_downbeat_every_three_beats():
    for seed in range(3):
        song = synthesize(20.0, 130.0, 8000, np.random.default_rng(seed), beats_per_bar=3)
        assert song.beats_per_bar == 3 and STYLES[song.style].beats_per_bar == 3
        np.testing.assert_array_equal(song.downbeats, song.beats[::3])
    assert synthesize(10.0, 120.0, 8000, np.random.default_rng(0), "waltz").beats_per_bar == 3
    assert synthesize(10.0, 120.0, 8000, np.random.default_rng(0), "backbeat").beats_per_bar == 4
    meters = {synthesize(4.0, 120.0, 8000, np.random.default_rng(s)).beats_per_bar for s in range(12)}
    assert meters == {3, 4}
    with pytest.raises(ValueError, match="3/4"):
        synthesize(10.0, 120.0, 8000, np.random.default_rng(0), "waltz", beats_per_bar=4)


def test_swing_delays_the_off_beats():
    np.testing.assert_allclose(swung(np.array([0.0, 0.5, 1.0, 1.25, 1.5, 1.75]), 0.6),
                               [0.0, 0.6, 1.0, 1.3, 1.6, 1.8])
    np.testing.assert_allclose(swung(np.array([0.0, 0.25, 0.5, 0.75]), 0.6, 16), [0.0, 0.3, 0.5, 0.8])
    np.testing.assert_allclose(swung(np.array([-1.0, -0.5, 2.0]), 0.5), [-1.0, -0.5, 2.0])
    for style in ("backbeat", "rock-34"):
        peaks = {}
        for swing in (0.5, 0.67):
            song = synthesize(30.0, 100.0, 22050, np.random.default_rng(1), style, swing=swing, swing_unit=8)
            assert song.swing == swing and song.swing_unit == 8 and song.drift > 0
            p = beat_profile(song, flux(song))  # 25 bins of 0.04 beat: 0.5 is bin 12.5, 0.67 bin 16.75
            peaks[swing] = p[11:15].max() / p[15:19].max()
        assert peaks[0.5] > 1.5 and peaks[0.67] < 1 / 1.5, (style, peaks)


@pytest.mark.parametrize("bpm", [70.0, 120.0, 180.0])
def test_the_beats_are_audible_onsets(bpm):
    for seed in range(4):
        song = synthesize(30.0, bpm, 22050, np.random.default_rng([int(bpm), seed]))
        env = flux(song)
        at_beats, typical = near(env, song.beats), np.median(env)
        assert np.median(at_beats) > 5 * typical, (song.style, np.median(at_beats) / typical)
        assert (at_beats > 3 * typical).mean() > 0.9, (song.style, (at_beats > 3 * typical).mean())


def test_noise_floor_and_peak():
    for snr in (20.0, 50.0):
        song = synthesize(10.0, 110.0, 8000, np.random.default_rng(2), snr_db=snr)
        assert np.abs(song.audio).max() == pytest.approx(0.9, abs=1e-6)
        frames = song.audio[: len(song.audio) // 80 * 80].reshape(-1, 80).astype(float)
        rms = np.sqrt((frames**2).mean(axis=1))
        floor = 20 * np.log10(rms.min() / np.sqrt((song.audio.astype(float) ** 2).mean()))
        assert -snr - 12 < floor < -snr + 6  # never digital silence: the quietest 10 ms is the noise floor


def test_a_minute_of_music_is_fast():
    rng = np.random.default_rng(0)
    t = time.perf_counter()
    song = synthesize(60.0, 150.0, 22050, rng)
    dt = time.perf_counter() - t
    print(f"60 s song ({song.style}) synthesized in {dt:.3f} s")
    assert dt < 3.0  # about 0.3 s on one free core; generous for shared machines


def test_the_librosa_tracker_finds_the_tempo():
    pytest.importorskip("dance_audio")
    from dance_audio.beats import track_beats
    from dance_core.media import Audio

    good = 0
    for seed in range(6):
        rng = np.random.default_rng(40 + seed)
        song = synthesize(20.0, float(rng.uniform(70, 180)), 22050, rng)
        tracked = track_beats(Audio(song.audio, song.rate), tracker="librosa").times
        ratio = np.median(np.diff(tracked)) / np.median(np.diff(song.beats))
        good += any(abs(ratio / m - 1) < 0.05 for m in (0.5, 1.0, 2.0))
    assert good >= 5
