"""Beat locking live (dance_core.live.beat_lock): beats from the tracker's phase, a dance whose pauses drift
against the beat played so that they land on it, causally."""

import numpy as np
import pytest

from dance_core.evaluation.realism import on_beat
from dance_core.live.beat_lock import MAX_LAG, MAX_RATE, RATE_FLOOR, BeatClock, BeatFeed, BeatLock
from dance_core.motion.body import body_beats
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24

FPS = 20.0
L_SHOULDER, R_SHOULDER, L_HIP, R_HIP = 16, 17, 1, 2


def tick(clock, beats, f):
    """Feed the clock music frame ``f``: the phase columns a tracker gives for ``beats`` (s)."""
    t = f / FPS
    k = np.searchsorted(beats, t, side="right") - 1
    phase = (t - beats[k]) / (beats[k + 1] - beats[k]) if 0 <= k < len(beats) - 1 else 0.0
    clock.update(f, np.sin(2 * np.pi * phase), np.cos(2 * np.pi * phase))


def clock_of(beats, seconds):
    """A clock fed ``seconds`` of music."""
    clock = BeatClock(FPS)
    for f in range(int(seconds * FPS)):
        tick(clock, beats, f)
    return clock


def test_the_clock_finds_beats_and_tempo_from_the_phase_and_predicts_the_next():
    beats = 0.13 + 0.5 * np.arange(30)  # 120 BPM, off the frame grid
    clock = clock_of(beats, 10.0)
    assert clock.period == pytest.approx(0.5, abs=0.01)
    found = np.array(clock.beats)
    assert len(found) >= 15 and np.abs(found - 0.13 - 0.5 * np.round((found - 0.13) / 0.5)).max() < 0.02
    ahead = clock.ahead(10.0, 1.2)
    np.testing.assert_allclose(ahead, [10.13, 10.63, 11.13], atol=0.03)
    assert BeatClock(FPS).ahead(0.0, 1.0).size == 0  # no tempo yet: nothing to steer to


def swinging(seconds):
    """A dance24 dancer swinging its arms and legs, pausing at the swings' ends: every 0.5 s on average, near
    the off-beat of a 120 BPM song (0.2 s after its beats), sooner or later by up to 0.1 s as it goes."""
    n = int(seconds * FPS)
    t = np.arange(n) / FPS
    swing = np.sin(np.pi * (t + 0.05) / 0.5 + 0.6 * np.sin(2 * np.pi * t / 3.3))
    rot = np.zeros((n, 24, 3))
    rot[:, L_SHOULDER, 2], rot[:, R_SHOULDER, 2] = -1.2 + 0.6 * swing, 1.2 + 0.6 * swing
    rot[:, L_HIP, 0], rot[:, R_HIP, 0] = 0.4 * swing, -0.4 * swing
    root = np.tile([0.0, 0.9, 0.0], (n, 1))
    return Motion(dance24(), FPS, root, expmap_to_quat(rot))


def test_a_dance_pausing_off_the_beat_is_played_onto_it():
    seconds = 30.0
    beats = 0.5 * np.arange(int(seconds / 0.5) + 4)
    dance = swinging(seconds)
    names, positions = dance.skeleton.names, dance.positions()
    before = on_beat(body_beats(positions, FPS, names), beats)
    clock = clock_of(beats, 0.55)  # the tracker has heard the music delay (0.55 s) past the frame made
    lock = BeatLock(dance.skeleton, FPS, clock)
    out, sources = [], []
    for f in range(dance.n_frames):
        tick(clock, beats, f + 11)
        lock.push(f, dance.root[f], dance.rotations[f], positions[f])
        out.append(lock.pose(f)[2])
        sources.append(lock.source)
        assert lock.source <= f  # never ahead of what was generated
    after = on_beat(body_beats(np.stack(out)[100:], FPS, names), beats[beats >= 5.0] - 5.0)
    assert before < 0 and after > 0.7, (before, after)  # locked within 5 s
    rates = np.diff(np.maximum(sources, 0))[40:]
    assert rates.min() >= 1 / MAX_RATE - 1e-9 and rates.max() <= MAX_RATE + 1e-9 and rates.std() > 0.05
    assert max(lock.lags) <= MAX_LAG + 1e-9 and lock.accents.count > 40


def pausing(seconds, seed):
    """A dance24 dancer sweeping its arms round at a steady speed, pausing for 0.1 s every 0.8-1.3 s (at
    random): its energy is flat between the pauses."""
    n, rng = int(seconds * FPS), np.random.default_rng(seed)
    speed, t = np.ones(n), 0.3
    while t < seconds:
        speed[int(t * FPS) : int(t * FPS) + 2] = 0.0
        t += rng.uniform(0.8, 1.3)
    angle = np.cumsum(speed) * 2 * np.pi * 0.8 / FPS
    rot = np.zeros((n, 24, 3))
    rot[:, L_SHOULDER, 1], rot[:, R_SHOULDER, 1] = angle, -angle  # the arms sweep round level
    return Motion(dance24(), FPS, np.tile([0.0, 0.9, 0.0], (n, 1)), expmap_to_quat(rot))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_rate_eases_while_the_body_moves_steadily_and_turns_at_its_changes(seed):
    seconds = 30.0
    beats = 0.5 * np.arange(int(seconds / 0.5) + 4)
    dance = pausing(seconds, seed)
    names, positions = dance.skeleton.names, dance.positions()
    clock = clock_of(beats, 0.55)
    lock = BeatLock(dance.skeleton, FPS, clock)
    out, steady, steps = [], [], []
    for f in range(dance.n_frames):
        tick(clock, beats, f + 11)
        lock.push(f, dance.root[f], dance.rotations[f], positions[f])
        rate, before = lock.rate, lock.source
        out.append(lock.pose(f)[2])
        if before >= 0 and f >= 40:
            now, last = lock.accents.energy_at(before), lock.accents.energy_at(before - rate)
            steady.append(abs(np.log(max(now, 1e-6) / max(last, 1e-6))) < 0.01)
            steps.append(abs(np.log(lock.rate / rate)))
    steady, steps = np.array(steady), np.array(steps)
    assert steady.mean() > 0.5 and steps[steady].max() <= RATE_FLOOR + 1e-9  # eased where the body is steady
    assert steps[~steady].max() > 3 * RATE_FLOOR  # free where its energy changes
    played = body_beats(np.stack(out)[100:], FPS, names)
    assert on_beat(played, beats[beats >= 5.0] - 5.0) > 0.4 > on_beat(body_beats(positions, FPS, names), beats)


def test_the_clock_steers_to_settled_beats_once_the_tracker_gives_them():
    beats = 0.5 * np.arange(40)  # what the tracker's phase says: 120 BPM on the whole seconds
    clock = clock_of(beats, 10.0)
    np.testing.assert_allclose(clock.ahead(10.1, 1.2), [10.5, 11.0], atol=0.03)
    clock.settle(np.array([8.25, 8.85, 9.45]))  # too few settled beats: the phase's still count
    np.testing.assert_allclose(clock.ahead(10.1, 1.2), [10.5, 11.0], atol=0.03)
    settled = 0.25 + 0.6 * np.arange(17)  # with hindsight: 100 BPM, off the phase's beats
    clock.settle(settled)
    assert clock.period == pytest.approx(0.6)
    np.testing.assert_allclose(clock.ahead(9.0, 2.0), [9.25, 9.85, 10.45], atol=1e-9)  # heard beats kept
    np.testing.assert_allclose(clock.ahead(10.0, 1.5), [10.45, 11.05], atol=1e-9)  # then predicted past them


def test_frames_skipped_are_held_and_the_accents_keep_their_frames():
    dance = swinging(6.0)
    positions = dance.positions()
    lock = BeatLock(dance.skeleton, FPS, clock_of(0.5 * np.arange(20), 2.0))
    for f in [*range(0, 60), *range(70, 100)]:  # frames 60-69 dropped
        lock.push(f, dance.root[f], dance.rotations[f], positions[f])
    held = lock._sample(65.0)[2]
    np.testing.assert_allclose(held, positions[59])  # a dropped frame shows the last pose made
    energy = [lock.accents.energy_at(k) for k in (62.0, 66.0)]
    assert max(energy) < 0.05 * lock.accents.energy_at(50.0)  # the hold is a pause, at the frames it is played


def test_the_feed_tells_the_clock_only_what_the_music_up_to_a_frame_told():
    """Rows and settled beats reach the clock for the music up to the newest frame a posed frame waited for,
    whatever arrived before: the same song gives the same clock, however far the audio ran ahead."""
    beats = 0.1 + 0.5 * np.arange(40)
    phase = [(t - beats[np.searchsorted(beats, t, "right") - 1]) / 0.5 for t in np.arange(300) / FPS]
    rows = np.zeros((300, 6))
    rows[:, 2], rows[:, 3] = np.sin(2 * np.pi * np.array(phase)), np.cos(2 * np.pi * np.array(phase))
    traces = [(k * 0.25, beats[beats < k * 0.25 - 0.3]) for k in range(1, 60)]

    def fed(chunks: int) -> list[tuple[float, int, int]]:
        clock, seen = BeatClock(FPS), []
        feed, step = BeatFeed(clock), 300 // chunks
        for lo in range(0, 300, step):  # the audio arrives in `chunks` pieces, ahead of the frames posed
            feed.add(rows[lo : lo + step], [t for t in traces if lo / FPS < t[0] <= (lo + step) / FPS])
            for newest in range(max(0, lo - 40), lo + step - 40):
                feed.advance(newest)
                seen.append((clock.phase, len(clock.beats), len(clock.settled)))
                assert clock.settled.size == 0 or clock.settled.max() < newest / FPS
        return seen

    assert fed(1)[:100] == fed(30)[:100] == fed(300)[:100]
    clock = BeatClock(FPS)
    feed = BeatFeed(clock)
    feed.add(rows[:100], [(None, beats[:5])])  # a trace with no time: at once
    feed.advance(10)
    assert len(clock.settled) == 5 and clock.phase == pytest.approx(phase[10] % 1.0)
