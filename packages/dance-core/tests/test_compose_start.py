"""``dance compose --start``: the dance composed for the song from a time on, its features those of the whole
song's frames from there (the music before it heard by the windows that look back), its markers from the
dance's first frame, ``--text`` spans in the song's time; bad starts one line before any work. A tiny
core-dance model (dance24, rotations) on a 10-s click track."""

import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.compose.songs import beat_tracker_of, load_model, load_song
from dance_core.errors import DataError
from dance_core.formats.bvh import BvhFormat
from dance_core.media import TextSpan
from dance_core.motion.markers import read_markers
from dance_core.recipe import load_recipe
from dance_core.recipe.schema import TextSpec
from dance_core.registry import get_registry
from dance_core.runtime import pick_device

sys.path.insert(0, str(Path(__file__).parent))
from compose_helpers import TINY, click_song, tiny_checkpoint  # noqa: E402


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A tiny core-dance checkpoint and a 10 s click-track song at 100 bpm."""
    root = tmp_path_factory.mktemp("start")
    checkpoint = tiny_checkpoint(root)
    return checkpoint, click_song(root / "song.wav", 10.0, bpm=100.0)


def compose_cli(model, out, *extra):
    checkpoint, song = model
    return main(["compose", "core-dance", *(f"--set={s}" for s in TINY), "--checkpoint", checkpoint,
                 "--music", song, "-o", str(out), "--quiet", "--format", "bvh", *extra])


def test_start_composes_from_there_with_the_songs_beats_from_the_dances_first_frame(model, tmp_path):
    pytest.importorskip("dance_audio")  # the beat tracker the markers need
    from dance_core.evaluation.song_markers import song_markers

    for run in ("a", "b"):
        assert compose_cli(model, tmp_path / run, "--start", "4", "--seconds", "3", "--markers") == 0
    dance = BvhFormat().read_motion(tmp_path / "a" / "song.bvh")
    assert dance.n_frames == 60 and dance.fps == 20.0  # 3 s of dance
    markers = read_markers(tmp_path / "a" / "song.markers.json")
    song = song_markers(model[1], get_registry())  # the whole song's beats, in its own time
    wanted = [t - 4.0 for t in song.beats if 4.0 <= t <= 7.0]
    assert len(wanted) >= 4 and markers.beats == pytest.approx(wanted, abs=1e-3)
    assert all(0.0 <= t <= 3.0 for t in markers.downbeats)
    for name in ("song.bvh", "song.markers.json"):  # the same seed, the same bytes
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    # without --seconds: to the song's end; a recipe field says the same
    assert compose_cli(model, tmp_path / "rest", "--start", "4") == 0
    assert BvhFormat().read_motion(tmp_path / "rest" / "song.bvh").n_frames == 120
    assert compose_cli(model, tmp_path / "field", "--set=compose.start=4", "--seconds", "3") == 0
    assert (tmp_path / "field" / "song.bvh").read_bytes() == (tmp_path / "a" / "song.bvh").read_bytes()


def test_features_are_the_whole_songs_from_the_start_and_texts_stay_in_the_songs_time(model):
    checkpoint, path = model
    recipe = load_recipe("core-dance", TINY)
    _, ckpt, stack = load_model(recipe, checkpoint, pick_device("cpu"))
    registry, tracker = get_registry(), beat_tracker_of(recipe, registry=get_registry())
    whole = load_song(path, stack, ckpt, None, registry)
    part = load_song(path, stack, ckpt, 3.0, registry, [TextSpec(text="a jump", start=5.0, end=6.0)], tracker,
                     start=4.0)
    assert part.n_frames == 60 and part.start == 4.0
    for name, values in part.streams.items():  # the music before the start is heard: the same features
        np.testing.assert_allclose(values, whole.streams[name][80:140], atol=1e-4)
    assert part.texts == (TextSpan("a jump", 1.0, 2.0),)  # the span in the dance's time
    assert part.spans.frames.tolist() == [[20, 40]]
    with pytest.raises(DataError, match="before the dance starts"):
        load_song(path, stack, ckpt, 3.0, registry, [TextSpec(text="a jump", start=1.0, end=3.0)], start=4.0)


def test_bad_starts_are_one_line_before_any_work(model, tmp_path, capsys):
    assert compose_cli(model, tmp_path / "plain", "--seconds", "3") == 0
    take = tmp_path / "plain" / "song.bvh"
    cases = [(["--start", "12"], "--start (compose.start) 12 s is at or after the song's end (10.0 s)"),
             (["--start", "-1"], "argument --start: must be"),
             (["--set=compose.start=-1"], "compose.start"),
             (["--start", "2", "--from", str(take), "--regenerate", "1-2"], "--start: not with --from")]
    for extra, message in cases:
        capsys.readouterr()
        try:
            rc = compose_cli(model, tmp_path / "bad", *extra)
        except SystemExit as exc:  # argparse's refusal
            rc = exc.code
        assert rc != 0, extra
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, (extra, err)
        assert not (tmp_path / "bad").exists() or not any((tmp_path / "bad").iterdir())
