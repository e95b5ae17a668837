"""A recipe's ``formats:`` gives motion formats and audio readers their options: validated with file:line
errors when the recipe loads, and applied wherever the recipe reads or writes a file by its suffix."""

from pathlib import Path

import numpy as np
import pytest

from dance_core import ComponentConfig, hookimpl
from dance_core.contexts import DatasetContext
from dance_core.data.features import FeatureStack, load_audio
from dance_core.data.prepare import cached_features
from dance_core.data.sources import ClipSource
from dance_core.errors import RecipeError
from dance_core.formats.configs import BvhFormatConfig
from dance_core.formats.wav import WavReader, write_wav
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry
from dance_core.synth.synthetic_dance import write_dataset
from dance_core.testing import registered_plugin


def test_options_are_validated_by_each_formats_config_with_file_and_line(tmp_path):
    recipe = tmp_path / "r.yaml"
    recipe.write_text("extends: core-dance\nformats:\n  bvh: {up: z, scale: 0.01}\n  npz: {compress: false}\n")
    options = load_recipe(recipe).format_options
    assert options.config("motion-format", "bvh") == BvhFormatConfig(up="z", scale=0.01)
    assert options.config("motion-format", "npz").compress is False
    assert options.config("audio-reader", "wav") is None  # not given: its defaults
    recipe.write_text("extends: core-dance\nformats:\n  bhv: {up: z}\n  bvh: {up: x}\n")
    with pytest.raises(RecipeError) as err:
        load_recipe(recipe)
    lines = str(err.value).splitlines()
    unknown = "unknown motion format or audio reader 'bhv' (did you mean 'bvh'?)"
    assert lines[0].startswith(f"{recipe}:3: formats.bhv: {unknown}")
    assert lines[1] == f"{recipe}:4: formats.bvh.up: Input should be 'y' or 'z'"


def test_a_recipe_without_formats_dumps_as_before():
    assert "formats" not in load_recipe("core-synthetic").model_dump(mode="json")  # run ids and checkpoints unchanged


def test_a_path_option_is_relative_to_the_recipe_that_wrote_it(tmp_path):
    (tmp_path / "r.yaml").write_text("extends: core-dance\nformats:\n  smpl: {model: models/SMPL.npz}\n")
    config = load_recipe(tmp_path / "r.yaml").format_options.config("motion-format", "smpl")
    assert config.model == str(tmp_path / "models" / "SMPL.npz")
    assert load_recipe(tmp_path / "r.yaml").model_dump()["formats"] == {"smpl": {"model": "models/SMPL.npz"}}


def test_a_folder_dataset_reads_its_motion_with_the_recipes_options(tmp_path):
    write_dataset(tmp_path / "pairs", songs=1, seed=4, seconds=3.0, fps=30.0, rate=8000)
    dataset = f"data.dataset={{plugin: folder, path: {tmp_path / 'pairs'}}}"

    def root_positions(*extra):
        recipe = load_recipe("core-dance", [dataset, *extra])
        context = DatasetContext(fps=recipe.fps, root=recipe.folder, formats=recipe.format_options)
        return recipe.data.dataset.build(context).clips()[0].motion.skeleton_motion.root

    np.testing.assert_allclose(root_positions("formats.bvh.scale=2"), 2 * root_positions(), rtol=1e-5)


class GainConfig(ComponentConfig):
    gain: float = 1.0


class GainReader:
    def __init__(self, config):
        self.gain = config.gain

    def read(self, path):
        audio = WavReader().read(path)
        return type(audio)(audio.samples * self.gain, audio.rate, audio.path)


class GainPlugin:
    @hookimpl
    def register_audio_readers(self, register):
        register("gain-wav", GainConfig, lambda config, **_: GainReader(config), suffixes=(".wav",), priority=99)


def test_audio_readers_receive_their_options_and_feature_caches_key_on_them(tmp_path):
    song = tmp_path / "song.wav"
    write_wav(song, np.full(8000, 0.25, np.float32), 8000)
    with registered_plugin(GainPlugin(), "gain") as registry:
        plain = load_recipe("core-synthetic")
        loud = load_recipe("core-synthetic", ["formats.gain-wav.gain=2"])
        assert load_audio(song, registry).samples.max() == pytest.approx(0.25)
        assert load_audio(song, registry, loud.format_options).samples.max() == pytest.approx(0.5)
        source = ClipSource("song", None, audio_path=str(song))
        cache = str(tmp_path / "cache")
        quiet_streams = cached_features(source, FeatureStack(plain), get_registry(), cache)
        loud_streams = cached_features(source, FeatureStack(loud), get_registry(), cache)
    assert FeatureStack(plain).reader_options() == {}
    assert len(list(Path(cache).rglob("*.npz"))) == 2  # one entry per reader setting
    assert not np.array_equal(quiet_streams["music"], loud_streams["music"])
