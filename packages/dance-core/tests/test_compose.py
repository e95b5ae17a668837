import math
import re

import numpy as np
import pytest

from dance_core.compose import compose
from dance_core.data.synthetic_beats import click_track
from dance_core.errors import CheckpointError, DataError, RecipeError
from dance_core.formats.wav import write_wav
from dance_core.train import train


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    from dance_core.recipe import load_recipe

    tiny = ["data.dataset.songs=4", "data.dataset.seconds=6", "training.steps=30", "training.batch_size=16"]
    run = tmp_path_factory.mktemp("run")
    return train(load_recipe("core-synthetic", tiny), out=str(run), quiet=True).checkpoint


def song(path, seconds=3.0, bpm=120.0, rate=16000, silent=False):
    beats = np.arange(0.0, seconds, 60 / bpm)
    audio = (
        np.zeros(int(seconds * rate), np.float32)
        if silent
        else click_track(beats, seconds, rate, np.random.default_rng(0))
    )
    write_wav(path, audio, rate)
    return str(path)


def test_compose_writes_every_song_and_sample_with_song_length(tiny_recipe, checkpoint, tmp_path):
    a, b = song(tmp_path / "a.wav", 3.0), song(tmp_path / "b.wav", 2.05, rate=22050)
    recipe = tiny_recipe("compose.samples=2")
    paths = compose(recipe, music=[a, b], checkpoint=str(checkpoint), out_dir=str(tmp_path / "out"), quiet=True)
    assert sorted(p.name for p in paths) == ["a-0.npz", "a-1.npz", "b-0.npz", "b-1.npz"]
    with np.load(tmp_path / "out" / "b-1.npz") as f:
        assert f["values"].shape == (math.ceil(2.05 * 20), 18)
        assert float(f["fps"]) == 20.0 and f["channels"][0] == "joint0.x"
    with np.load(tmp_path / "out" / "a-0.npz") as f:
        assert f["values"].shape == (60, 18) and np.isfinite(f["values"]).all()


def test_same_seed_same_dance_and_seconds_option(tiny_recipe, checkpoint, tmp_path):
    s = song(tmp_path / "s.wav", 2.0)
    outs = []
    for i, extra in enumerate([(), (), ("seed=5",)]):
        out = tmp_path / f"o{i}"
        compose(
            tiny_recipe(*extra, "compose.seconds=3.5"),
            music=[s],
            checkpoint=str(checkpoint),
            out_dir=str(out),
            quiet=True,
        )
        with np.load(out / "s.npz") as f:
            outs.append(f["values"])
    assert outs[0].shape == (70, 18)  # longer than the song: the music is padded past its end
    np.testing.assert_array_equal(outs[0], outs[1])


def test_silence_and_short_songs_work(tiny_recipe, checkpoint, tmp_path):
    s = song(tmp_path / "quiet.wav", 1.0, silent=True)
    paths = compose(tiny_recipe(), music=[s], checkpoint=str(checkpoint), out_dir=str(tmp_path), quiet=True)
    with np.load(paths[0]) as f:
        assert f["values"].shape == (20, 18) and np.isfinite(f["values"]).all()


def test_bad_music_gives_one_line_errors(tiny_recipe, checkpoint, tmp_path):
    recipe = tiny_recipe()
    cases = {
        "missing.wav": "audio file not found",
        "empty.wav": "audio file is empty",
        "corrupt.wav": "not a WAV file|cannot decode audio",  # core's reader, or dance-audio's
        "song.xyz": "no audio reader for '.xyz'",
    }
    (tmp_path / "empty.wav").write_bytes(b"")
    (tmp_path / "corrupt.wav").write_bytes(b"hello, not audio" * 10)
    (tmp_path / "song.xyz").write_bytes(b"data")
    for name, message in cases.items():
        with pytest.raises(DataError) as err:
            compose(
                recipe,
                music=[str(tmp_path / name)],
                checkpoint=str(checkpoint),
                out_dir=str(tmp_path / "o"),
                quiet=True,
            )
        assert re.search(message, str(err.value)) and name in str(err.value) and "\n" not in str(err.value)
    short = song(tmp_path / "tiny.wav", 0.2)
    with pytest.raises(DataError, match="0.20 s long"):
        compose(recipe, music=[short], checkpoint=str(checkpoint), out_dir=str(tmp_path / "o"), quiet=True)
    assert not (tmp_path / "o").exists()  # nothing half-written


def test_compose_needs_a_matching_checkpoint(tiny_recipe, checkpoint, tmp_path):
    s = song(tmp_path / "s.wav")
    with pytest.raises(RecipeError, match="compose.checkpoint"):
        compose(tiny_recipe(), music=[s], out_dir=str(tmp_path), quiet=True)
    with pytest.raises(CheckpointError, match="model.head.loss differ"):
        compose(
            tiny_recipe("model.head.loss=l2"), music=[s], checkpoint=str(checkpoint), out_dir=str(tmp_path), quiet=True
        )


def test_seed_motion_file(tiny_recipe, checkpoint, tmp_path):
    from dance_core.formats.npz import NpzFormat
    from dance_core.protocols import MotionData

    s = song(tmp_path / "s.wav", 2.0)
    seed = np.tile(np.linspace(0, 1, 18, dtype=np.float32), (4, 1))
    NpzFormat().write(MotionData(seed, 20.0), tmp_path / "seed.npz")
    paths = compose(
        tiny_recipe(f"compose.seed_motion={tmp_path / 'seed.npz'}"),
        music=[s],
        checkpoint=str(checkpoint),
        out_dir=str(tmp_path / "o"),
        quiet=True,
    )
    with np.load(paths[0]) as f:
        np.testing.assert_allclose(f["values"][:10], np.tile(seed[:1], (10, 1)), atol=1e-5)
    NpzFormat().write(MotionData(seed[:, :5], 20.0), tmp_path / "bad.npz")
    with pytest.raises(DataError, match="5 channels"):
        compose(
            tiny_recipe(f"compose.seed_motion={tmp_path / 'bad.npz'}"),
            music=[s],
            checkpoint=str(checkpoint),
            out_dir=str(tmp_path / "o"),
            quiet=True,
        )


def test_output_formats_are_written_with_the_recipes_format_options(tiny_recipe, checkpoint, tmp_path):
    import zipfile

    s = song(tmp_path / "s.wav", 1.0)
    for compress, method in ((True, zipfile.ZIP_DEFLATED), (False, zipfile.ZIP_STORED)):
        out = tmp_path / str(compress)
        [path] = compose(tiny_recipe(f"formats.npz.compress={str(compress).lower()}"), music=[s],
                         checkpoint=str(checkpoint), out_dir=str(out), quiet=True)
        with zipfile.ZipFile(path) as z:
            assert {info.compress_type for info in z.infolist()} == {method}


def test_threads_option_sets_torch_threads(tiny_recipe, checkpoint, tmp_path):
    import torch

    before = torch.get_num_threads()
    try:
        s = song(tmp_path / "s.wav", 1.0)
        compose(tiny_recipe("compose.threads=1"), music=[s], checkpoint=str(checkpoint), out_dir=str(tmp_path),
                quiet=True)
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)
