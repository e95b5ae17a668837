"""Text in composition: ``--text``/``compose.texts`` reach a model that reads text, change its dance
inside the span only (for a windowed model: from the span's start minus its look-ahead), and are refused
with one line by a model that reads none."""

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.compose import compose
from dance_core.data.synthetic_beats import click_track
from dance_core.errors import DataError, RecipeError
from dance_core.formats.wav import write_wav
from dance_core.recipe import load_recipe
from dance_core.recipe.schema import TextSpec
from dance_core.train import train


@pytest.fixture(scope="module")
def text_model(tmp_path_factory):
    pytest.importorskip("dance_audio")
    root = tmp_path_factory.mktemp("text-model")
    (root / "vocab.txt").write_text("a\nperson\njumps\nclaps\n")
    sets = ["data.dataset.songs=3", "data.dataset.seconds=6", "training.steps=10", "training.batch_size=8",
            f"features.text=[{{plugin: word-tokens, vocab: {root / 'vocab.txt'}, max_words: 4}}]"]
    ckpt = train(load_recipe("core-synthetic", sets), out=str(root / "run"), quiet=True).checkpoint
    rate = 16000
    write_wav(root / "song.wav", click_track(np.arange(0, 4, 0.5), 4.0, rate, np.random.default_rng(0)), rate)
    return root, sets, str(ckpt)


def dance(root, sets, ckpt, name, *texts):
    recipe = load_recipe("core-synthetic", [*sets, f"compose.texts={[t.model_dump() for t in texts]}"])
    [path] = compose(recipe, music=[str(root / "song.wav")], checkpoint=ckpt, out_dir=str(root / name), quiet=True)
    with np.load(path) as f:
        return f["values"]


def test_text_span_changes_the_dance_only_from_its_window(text_model):
    root, sets, ckpt = text_model
    plain = dance(root, sets, ckpt, "plain")
    jumped = dance(root, sets, ckpt, "jump", TextSpec.parse("2-3: a person jumps"))
    # the window-mlp sees 6 conditioning frames ahead at 20 fps: the text reaches frame 40 - 6 = 34 first
    np.testing.assert_array_equal(jumped[:34], plain[:34])
    assert not np.allclose(jumped[34:60], plain[34:60])
    again = dance(root, sets, ckpt, "jump2", TextSpec.parse("2-3: a person jumps"))
    np.testing.assert_array_equal(again, jumped)  # deterministic


def test_text_past_the_song_and_text_for_a_text_free_model_are_one_line(text_model, tmp_path, capsys):
    root, sets, ckpt = text_model
    with pytest.raises(DataError, match=r"compose.texts.0: starts at 9 s, after the song's end \(4.0 s\)"):
        dance(root, sets, ckpt, "late", TextSpec.parse("9-10: a person claps"))
    with pytest.raises(RecipeError, match="compose.texts: this model reads no text"):
        compose(load_recipe("core-synthetic", ["compose.texts=[{text: a person jumps}]"]),
                music=[str(root / "song.wav")], checkpoint=str(tmp_path / "none.safetensors"), quiet=True)
    assert main(["compose", "core-synthetic", "--music", str(root / "song.wav"), "--text", "5-1: jump"]) == 1
    assert "--text '5-1: jump': end (1 s) must come after start (5 s)" in capsys.readouterr().err


def test_text_spec_parses_spans():
    assert TextSpec.parse("20-30: a person jumps") == TextSpec(text="a person jumps", start=20, end=30)
    assert TextSpec.parse("a person spins") == TextSpec(text="a person spins")
    assert TextSpec.parse("12.5-: spin") == TextSpec(text="spin", start=12.5)
    assert TextSpec.parse("note: 3-4 things").text == "note: 3-4 things"
