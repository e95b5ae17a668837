"""The beats extractor live: the flux tracker's forward pass against its offline Viterbi decoding."""

from __future__ import annotations

import numpy as np

from dance_audio.beats import BeatFeatures, track_beats
from dance_audio.online_beats import OnlineBeats


def _stream(audio, seconds: float, fps: float = 20.0, block: int = 512) -> np.ndarray:
    y = audio.samples[: int(seconds * audio.rate)]
    live = OnlineBeats(fps, audio.rate, [3, 4], 55.0, 160.0)
    rows = [live.push(y[lo : lo + block]) for lo in range(0, len(y), block)]
    rows.append(live.finish(int(np.ceil(len(y) / audio.rate * fps))))
    return np.concatenate(rows)


def test_online_beats_follow_the_offline_tracker(audio_dir, registry, make_clicks):
    from dance_core.data.features import load_audio

    audio = load_audio(audio_dir / "vibe_ace.ogg", registry)
    cols = _stream(audio, 40.0)
    assert cols.shape == (800, 6) and np.all(np.isfinite(cols))
    online = np.flatnonzero(cols[:, 0]) / 20.0
    offline = track_beats(audio.__class__(audio.samples[: 40 * audio.rate], audio.rate)).times
    after = offline[offline > 5.0]  # locked within 5 s: most offline beats have a live beat within 70 ms
    hits = sum(np.min(np.abs(online - t)) <= 0.07 for t in after)
    assert hits >= 0.85 * len(after)
    assert abs(np.median(np.diff(online[online > 5])) / np.median(np.diff(after)) - 1) < 0.05
    # downbeats are beats, phases are unit circles
    assert np.all(cols[cols[:, 1] > 0, 0] == 1)
    assert np.allclose(cols[:, 2] ** 2 + cols[:, 3] ** 2, 1, atol=1e-5)


def test_online_beats_follow_a_tempo_change(make_clicks):
    times = np.r_[np.arange(0.5, 15.0, 0.5), np.arange(15.0, 30.0, 0.4)]  # 120 then 150 BPM
    audio = make_clicks(times, 30.0)
    online = np.flatnonzero(_stream(audio, 30.0, fps=100.0)[:, 0]) / 100.0
    early = np.diff(online[(online > 5) & (online < 14.5)])
    late = np.diff(online[online > 20])
    assert abs(np.median(early) - 0.5) < 0.03 and abs(np.median(late) - 0.4) < 0.03


def test_streaming_is_offered_by_the_extractor():
    live = BeatFeatures("flux", [3, 4], 55.0, 160.0).streaming(20.0, 44100)
    assert live.dim() == 6 and 0 < live.lookahead < 0.05


def test_settled_beats_place_heard_beats_with_hindsight(make_clicks):
    from dance_audio.online_beats import SETTLE_WINDOW, SettledBeats

    times = np.r_[np.arange(0.5, 15.0, 0.5), np.arange(15.0, 30.0, 0.4)]  # 120 then 150 BPM
    audio = make_clicks(times, 30.0)
    live = OnlineBeats(100.0, audio.rate, [4], 55.0, 160.0)
    seen = []
    for lo in range(0, len(audio.samples), 2205):  # 0.1-s blocks
        live.push(audio.samples[lo : lo + 2205])
        seen.append(live.settled_beats().copy())
    settled = live.settled_beats()
    assert settled.min() >= 30.0 - SETTLE_WINDOW - 0.01  # only the window is kept
    heard = times[(times > settled.min() + 1) & (times < 29.0)]
    assert len(heard) > 20 and max(np.min(np.abs(settled - t)) for t in heard) < 0.02  # every click, on time
    assert abs(np.median(np.diff(settled[settled > 20])) - 0.4) < 0.01
    # re-decoded as the music comes: at 10 s the beats heard so far were there already
    early = seen[int(np.ceil(10.0 * audio.rate / 2205))]  # the settled beats after the block reaching 10 s
    assert early.max() < 10.2 and max(np.min(np.abs(early - t)) for t in times[(times > 2) & (times < 9.5)]) < 0.02
    assert SettledBeats(55.0, 160.0).times.size == 0


def test_settled_beats_are_the_offline_decoding_of_what_was_heard():
    from dance_audio.flux_beats import FPS, decode_beats
    from dance_audio.online_beats import SettledBeats

    rng = np.random.default_rng(0)
    t = np.arange(2600) / FPS  # 26 s, longer than the window traced back
    period = 0.5 + 0.04 * np.sin(2 * np.pi * t / 11.0)  # a drifting tempo
    phase = np.cumsum(1.0 / (period * FPS)) % 1.0
    p = np.clip(0.02 + 0.88 * np.exp(-((np.minimum(phase, 1 - phase) * period) / 0.02) ** 2)
                * rng.uniform(0.3, 1.0, len(t)) + rng.uniform(0.0, 0.2, len(t)), 0.02, 0.9)
    settled = SettledBeats(55.0, 160.0)
    for k, value in enumerate(p, 1):
        settled.push(value)
        if k in (900, len(p) - len(p) % 25):  # traced every 25 frames: compare with Viterbi over all heard
            offline = decode_beats(p[:k], 55.0, 160.0) / FPS
            kept = offline[offline >= settled.times.min() - 1e-9]
            assert len(settled.times) > 10 and np.array_equal(settled.times, kept)


def test_each_placing_of_the_settled_beats_is_given_once_with_when_whatever_the_blocks(make_clicks):
    from dance_audio.online_beats import SETTLE_EVERY

    audio = make_clicks(np.arange(0.5, 12.0, 0.5), 12.0)
    takes = {}
    for block in (300, 2205, 30000):
        live, traces = OnlineBeats(20.0, audio.rate, [4], 55.0, 160.0), []
        for lo in range(0, len(audio.samples), block):
            live.push(audio.samples[lo : lo + block])
            traces += live.take_settled()
            if traces:
                assert np.array_equal(traces[-1][1], live.settled_beats())  # the latest is the one in force
        assert live.take_settled() == []  # each given once
        takes[block] = traces
    heard = [t for t, _ in takes[300]]
    assert np.allclose(np.diff(heard), SETTLE_EVERY, atol=0.011) and 11.5 < heard[-1] <= 12.0
    for block in (2205, 30000):  # the same placings, at the same points of the music, however the audio came
        assert [t for t, _ in takes[block]] == heard
        assert all(np.array_equal(a, b) for (_, a), (_, b) in zip(takes[block], takes[300], strict=True))
