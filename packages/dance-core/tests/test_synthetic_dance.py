from pathlib import Path

import numpy as np
import pytest

from dance_core.formats.bvh import BvhFormat
from dance_core.synth.dancer import MOVES
from dance_core.synth.synthetic_dance import make_clip, write_dataset

KW = {"seconds": 20.0, "bpm": (80.0, 140.0), "rate": 11025, "fps": 60.0}


@pytest.fixture(scope="module")
def clips():
    return [make_clip(i, seed=7, **KW) for i in range(4)]


def test_same_seed_same_song_and_dance():
    a, b = make_clip(2, seed=3, **KW), make_clip(2, seed=3, **KW)
    np.testing.assert_array_equal(a.audio.samples, b.audio.samples)
    np.testing.assert_array_equal(a.motion.values, b.motion.values)
    assert a.texts == b.texts
    c = make_clip(2, seed=4, **KW)
    assert c.meta["bpm"] != a.meta["bpm"]


def test_the_dancers_hips_bottom_out_on_the_beats(clips):
    for clip in clips:
        fps = clip.motion.fps
        y = clip.motion.skeleton_motion.positions()[:, 0, 1]  # pelvis height
        v = np.diff(y)
        turns = np.flatnonzero((v[:-1] < 0) & (v[1:] >= 0)) + 1  # vertical velocity turns from down to up
        beat_frames = np.asarray(clip.meta["beats"]) * fps
        inside = beat_frames[(beat_frames > 2) & (beat_frames < len(y) - 3)]
        assert len(turns) >= len(inside) - 1
        # every bottom is within one frame of a beat, and every beat has a bottom within one frame
        assert np.abs(turns[:, None] - beat_frames[None]).min(axis=1).max() <= 1.0
        assert np.abs(inside[:, None] - turns[None]).min(axis=1).max() <= 1.0


def test_moves_are_labelled_with_time_spans_and_vary(clips):
    seen = set()
    for clip in clips:
        spans = clip.texts
        assert spans and all(t.text in MOVES.values() for t in spans)
        assert all(0 <= t.start < t.end <= KW["seconds"] for t in spans)
        assert all(a.end == pytest.approx(b.start) for a, b in zip(spans[:-1], spans[1:], strict=True))
        seen |= {t.text for t in spans}
    assert len(MOVES) >= 8 and len(seen) >= 5
    many = {t.text for i in range(12) for t in make_clip(i, seed=1, **{**KW, "seconds": 30.0}).texts}
    assert len(many) == len(MOVES)


def test_one_song_admits_several_dances():
    a, b = (make_clip(i, seed=2, dances_per_song=2, **KW) for i in (0, 1))
    np.testing.assert_array_equal(a.audio.samples, b.audio.samples)
    assert a.name == "synth-0000-0" and b.name == "synth-0000-1"
    assert np.abs(a.motion.values - b.motion.values).max() > 0.1


def test_the_dancer_stays_on_its_feet_and_moves_smoothly(clips):
    for clip in clips:
        pos = clip.motion.skeleton_motion.positions()
        feet = pos[:, [10, 11], 1].min(axis=1)
        assert feet.min() > -0.05 and np.median(feet) < 0.1
        speed = np.linalg.norm(np.diff(pos, axis=0), axis=-1).max() * clip.motion.fps
        # m/s: no teleporting joints (the fastest, 12.1 m/s, is a hand swung smoothly down from overhead
        # between moves: 11.0 m/s on SMPL's template, whose arms from the shoulder are 10 % shorter)
        assert speed < 13.0
        travel = np.linalg.norm(pos[:, 0, [0, 2]] - pos[0, 0, [0, 2]], axis=-1)
        assert travel.max() < 6.0


def test_written_dataset_has_audio_bvh_beats_and_labels(tmp_path):
    names = write_dataset(tmp_path, songs=2, seed=1, seconds=6.0, fps=30.0, rate=8000)
    assert names == ["synth-0000", "synth-0001"]
    clip = make_clip(1, seed=1, seconds=6.0, bpm=(80.0, 140.0), rate=8000, fps=30.0)
    motion = BvhFormat().read_motion(tmp_path / "synth-0001.bvh").conformed(clip.motion.skeleton_motion.skeleton)
    np.testing.assert_allclose(motion.positions(), clip.motion.skeleton_motion.positions(), atol=1e-3)
    beats = np.loadtxt(tmp_path / "synth-0001.beats")
    np.testing.assert_allclose(beats[:, 0], clip.meta["beats"], atol=1e-4)
    assert list(beats[:4, 1]) == [1, 2, 3, 4]
    first = (tmp_path / "synth-0001.texts").read_text().splitlines()[0].split("\t")
    assert first[2] == clip.texts[0].text and float(first[1]) == pytest.approx(clip.texts[0].end)
    sections = (tmp_path / "synth-0001.sections").read_text().splitlines()
    assert sections[0].startswith("# bpm ") and sections[1].split("\t")[2] == "intro"


def test_dance_synth_cli_writes_the_dataset_and_keeps_the_click_track(tmp_path, capsys):
    from dance_core.cli.main import main

    assert main(["synth", "--out", str(tmp_path / "d"), "--songs", "2", "--seconds", "3", "--seed", "5",
                 "--fps", "20", "--rate", "8000"]) == 0
    assert sorted(p.name for p in (tmp_path / "d").iterdir())[:5] == [
        "synth-0000.beats", "synth-0000.bvh", "synth-0000.sections", "synth-0000.texts", "synth-0000.wav"]
    assert BvhFormat().read_motion(tmp_path / "d" / "synth-0001.bvh").n_frames == 60
    assert main(["synth", str(tmp_path / "click.wav"), "--seconds", "1"]) == 0
    assert (tmp_path / "click.wav").stat().st_size > 1000
    assert main(["synth"]) == 1 and "--out DIR" in capsys.readouterr().err


@pytest.mark.parametrize("style", ["four-on-the-floor", "backbeat", "hiphop", "latin"])
def test_the_music_is_loud_on_its_beats_in_every_style(style):
    from dance_core.synth.music import synthesize

    song = synthesize(30.0, 112.0, 8000, np.random.default_rng(5), style)
    hop = 80  # 10 ms frames
    frames = song.audio[: len(song.audio) // hop * hop].reshape(-1, hop)
    energy = np.log(1e-6 + (frames**2).mean(axis=1))
    onset = np.maximum(np.diff(energy, prepend=energy[0]), 0)
    at = lambda times: onset[np.clip(np.round(np.asarray(times) * 100).astype(int), 0, len(onset) - 1)]  # noqa: E731
    near = lambda times: np.max([at(times + d) for d in (-0.01, 0.0, 0.01)], axis=0)  # noqa: E731
    beat_strength = near(song.beats)
    between = near(song.beats[:-1] + np.diff(song.beats) * 0.37)  # off the 16th-note grid
    assert np.median(between) > 0.05  # the measure sees pads and tails between beats, not silence
    assert (beat_strength > 3 * np.median(between)).mean() >= 0.95  # beats are clear onsets, intro included
    assert [name for name, _, _ in song.section_bars][0] == "intro" and len(song.downbeats) == len(song.beats[::4])


MOCAP = Path(__file__).resolve().parents[3] / ".." / "shared" / "mocap" / "cmu-dance"


@pytest.mark.skipif(not MOCAP.is_dir(), reason="../shared/mocap not available")
def test_written_dataset_from_real_moves_has_real_moves_in_every_clip(tmp_path):
    # one process: every clip of `dance synth --out --songs N --mocap` is chained from the takes (the first
    # clip alone was, the others fell back to the procedural dancer with its move labels)
    names = write_dataset(tmp_path, songs=2, seed=1, seconds=6.0, fps=30.0, rate=8000, dances_per_song=2,
                          mocap=str(MOCAP), mocap_exclude=("salsa_*", "modern_05_0[4-9].bvh", "modern_05_1?.bvh"))
    assert len(names) == 4
    assert all((tmp_path / f"{n}.texts").read_text() == "" for n in names)
