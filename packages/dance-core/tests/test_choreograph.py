from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.errors import DataError
from dance_core.evaluation.quality import hip_height_beats, phase_locking, wrong_tempo_grid
from dance_core.formats.bvh import BvhFormat
from dance_core.synth.beat_grid import BeatGrid
from dance_core.synth.choreograph import find_sections
from dance_core.synth.dancer import Style, dance

FIXTURES = Path(__file__).resolve().parents[3].parent / "shared" / "fixtures" / "audio"
SONG = FIXTURES / "hungarian_dance_5.ogg"


def test_beat_grid_interpolates_uneven_beats_and_inverts():
    times = np.array([0.5, 1.0, 1.6, 2.1, 2.8, 3.3])
    grid = BeatGrid(times, 3, first_downbeat=1)
    np.testing.assert_allclose(grid.beat_at(times), np.arange(6) - 1)
    t = np.linspace(-1.0, 5.0, 61)
    np.testing.assert_allclose(grid.time_of(grid.beat_at(t)), t, atol=1e-9)
    assert grid.beat_at(0.0) == pytest.approx(-1 - 0.5 / 0.5)  # extrapolated with the first interval
    np.testing.assert_allclose(grid.downbeats(), [1.0, 2.8])
    with pytest.raises(DataError):
        BeatGrid(np.array([1.0, 1.0, 2.0]), 4)


def test_grid_from_tracked_positions_finds_the_meter():
    times = np.arange(14) * 0.5
    positions = (np.arange(14) + 2) % 3 + 1  # 3, 1, 2, 3, 1, ...: bars of 3 from the second beat
    grid = BeatGrid.from_positions(times, positions)
    assert grid.beats_per_bar == 3 and grid.first_downbeat == 1


@pytest.mark.parametrize("beats_per_bar", [3, 4])
def test_the_dancer_follows_uneven_beats(beats_per_bar):
    rng = np.random.default_rng(3)
    intervals = 0.5 * (1 + 0.06 * np.sin(np.arange(60) / 5)) + rng.uniform(-0.01, 0.01, 60)  # a live band
    times = 0.3 + np.concatenate([[0], np.cumsum(intervals)])
    grid = BeatGrid(times, beats_per_bar)
    fps, seconds = 60.0, 25.0
    bars = grid.bars(seconds)
    motion, texts = dance(grid, [i % 9 for i in range(bars)], seconds, fps, Style.draw(rng))
    positions = motion.positions()
    lows = hip_height_beats(positions, fps)
    inside = times[(times > 0.5) & (times < seconds - 0.5)]
    assert np.abs(inside[:, None] - lows[None]).min(axis=1).max() <= 1.5 / fps  # a hip low on every beat
    assert phase_locking(lows, times) > 0.95
    assert phase_locking(lows, wrong_tempo_grid(times)) < 0.5
    starts = [t.start for t in texts[1:]]
    downbeats = times[::beats_per_bar]
    assert all(np.abs(downbeats - s).min() < 1e-3 for s in starts)  # moves change on downbeats


def test_sections_split_at_changes_and_name_loud_parts_chorus():
    quiet, loud = np.zeros((8, 7)), np.ones((8, 7))
    feats = np.concatenate([quiet, loud, quiet * 0.5 + 0.25, loud, quiet]) + 0.01 * np.arange(40)[:, None] % 0.02
    sections = find_sections(feats)
    assert [s[1] for s in sections] == [0, 8, 16, 24, 32]
    assert sections[0][0] == "intro" and sections[1][0] == "chorus" and sections[-1][0] == "outro"


@pytest.mark.skipif(not SONG.exists(), reason="shared fixtures not found")
def test_synth_music_places_the_dancers_beats_on_the_tracked_beats(tmp_path, capsys):
    out = tmp_path / "dances"
    assert main(["-q", "synth", "--music", str(SONG), "--out", str(out), "--dances", "2", "--fps", "30"]) == 0
    names = sorted(p.stem for p in out.glob("*.bvh"))
    assert names == ["hungarian_dance_5-0", "hungarian_dance_5-1"]
    assert (out / "hungarian_dance_5-0.ogg").stat().st_size == SONG.stat().st_size
    rows = [ln.split("\t") for ln in (out / "hungarian_dance_5-0.beats").read_text().splitlines()]
    beats = np.array([float(r[0]) for r in rows])
    assert 40 < len(beats) < 140 and {r[1] for r in rows} >= {"1", "2", "3"}
    dances = []
    for name in names:
        motion = BvhFormat().read(str(out / f"{name}.bvh")).skeleton_motion
        positions = motion.positions()
        lows = hip_height_beats(positions, motion.fps)
        assert phase_locking(lows, beats) > 0.9
        assert phase_locking(lows, wrong_tempo_grid(beats)) < 0.4
        dances.append(positions)
    assert np.abs(dances[0] - dances[1]).max() > 0.2  # two different dances to one song
    texts = (out / "hungarian_dance_5-1.texts").read_text().splitlines()
    assert len(texts) >= 3 and all(len(t.split("\t")) == 3 for t in texts)


def test_synth_music_rejects_missing_songs_in_one_line(tmp_path, capsys):
    assert main(["synth", "--music", str(tmp_path / "nope.ogg"), "--out", str(tmp_path / "o")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope.ogg" in err[0] and "--music" in err[0]
    assert main(["synth", "--music", str(tmp_path)]) != 0
    assert "--out" in capsys.readouterr().err
