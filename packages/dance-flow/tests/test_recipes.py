"""The bundled recipes: paper sizes, a few training steps each, learning, and composing."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dance_core.compose import compose
from dance_core.model import build_model
from dance_core.recipe import load_recipe
from dance_core.train import train

# shrink the paper-size recipes to a few seconds of CPU while keeping their structure
TINY_DATA = [
    "data.dataset.songs=3",
    "data.dataset.seconds=8",
    "training.batch_size=8",
    "training.val_every=1000",
    "training.log_every=1",
    "features.music=[{plugin: energy}]",
    "compose.formats=[npz]",
]
TINY = {
    "transflower": [
        "model.encoder.motion_past=12",
        "model.encoder.cond_past=12",
        "model.encoder.cond_future=4",
        "model.encoder.dim=16",
        "model.encoder.motion={layers: 1, heads: 2}",
        "model.encoder.music={layers: 1, heads: 2}",
        "model.encoder.crossmodal={layers: 2, heads: 2}",
        "model.head.steps=2",
        "model.head.coupling={dim: 8, layers: 1, heads: 2}",
    ],
    "aichoreographer": [
        "model.encoder.motion_past=12",
        "model.encoder.cond_past=12",
        "model.encoder.cond_future=4",
        "model.encoder.dim=16",
        "model.encoder.motion={layers: 1, heads: 2}",
        "model.encoder.music={layers: 1, heads: 2}",
        "model.encoder.crossmodal={layers: 1, heads: 2}",
        "model.head.hidden=16",
    ],
    "moglow": [
        "model.encoder.motion_frames=4",
        "model.encoder.music_past=4",
        "model.encoder.music_future=2",
        "model.encoder.steps=4",
        "model.encoder.hidden=16",
        "model.encoder.dim=16",
        "model.head.steps=2",
        "model.head.coupling={dim: 8, layers: 1, heads: 2}",
    ],
    "transflower-small": ["model.encoder.motion_past=12", "model.encoder.cond_past=12", "model.encoder.cond_future=4"],
}


def test_transflower_recipe_has_the_papers_size():
    recipe = load_recipe("transflower")
    enc, head = recipe.model.encoder.config, recipe.model.head.config
    assert (enc.motion_past, enc.cond_past, enc.cond_future) == (120, 120, 20)
    assert (enc.dim, enc.motion.layers, enc.music.layers, enc.crossmodal.layers) == (800, 2, 2, 12)
    assert (head.steps, head.coupling.layers, head.frames, head.keep) == (16, 2, 3, 1)
    assert recipe.fps == 20
    model = build_model(recipe, 69, {"music": 85})  # the paper's motion and music widths
    count = sum(p.numel() for p in model.parameters())
    assert 115e6 < count < 125e6  # the paper reports 122 M


@pytest.mark.parametrize("name", list(TINY))
def test_recipe_trains_a_few_steps_and_composes(name, tmp_path, demo_song):
    recipe = load_recipe(name, [*TINY_DATA, *TINY[name], "training.steps=3"])
    result = train(recipe, out=str(tmp_path / "run"), quiet=True)
    assert np.isfinite(result.first_loss) and np.isfinite(result.last_loss)
    written = compose(
        recipe, music=[str(demo_song)], checkpoint=str(result.checkpoint), out_dir=str(tmp_path / "out"), quiet=True
    )
    motion = np.load(written[0])
    values = motion[[k for k in motion.files if motion[k].ndim == 2][0]]
    assert values.shape[0] == 60 and np.all(np.isfinite(values))  # the whole 3 s song at 20 fps


def test_transflower_small_learns_the_synthetic_dance(tmp_path):
    sets = [
        *TINY_DATA,
        *TINY["transflower-small"],
        "data.dataset.songs=10",
        "data.val_fraction=0.2",
        "training.steps=60",
        "training.batch_size=16",
        "training.optimizer.lr=2e-3",
        "training.val_every=20",
    ]
    recipe = load_recipe("transflower-small", sets)
    train(recipe, out=str(tmp_path / "run"), quiet=True)
    log = [json.loads(line) for line in (tmp_path / "run" / "log.jsonl").read_text().splitlines()]
    losses = [r["loss"] for r in log if "loss" in r]
    val = [r["val_loss"] for r in log if "val_loss" in r]
    assert np.mean(losses[-10:]) < np.mean(losses[:5]) - 1.0  # bits per dimension
    assert len(val) == 3 and val[2] < val[0] - 0.3  # and on held-out songs


def test_aichoreographer_uses_cores_regression_head():
    recipe = load_recipe("aichoreographer", TINY["aichoreographer"])
    model = build_model(recipe, 6, {"music": 4})
    assert type(model.head).__name__ == "RegressionHead"
    assert type(model.encoder).__name__ == "TransflowerEncoder"
    assert model.encoder.latent_tokens == model.head.frames == 3


@pytest.fixture
def demo_song(tmp_path):
    """A 3-second synthesized song."""
    from dance_core.data.synthetic_beats import click_track
    from dance_core.formats.wav import write_wav

    rate = 16000
    audio = click_track(np.arange(0.1, 3.0, 0.5), 3.0, rate, np.random.default_rng(0))
    path = tmp_path / "song.wav"
    write_wav(path, audio, rate)
    return path


def test_temperature_zero_composes_the_same_dance_twice(tmp_path, demo_song):
    recipe = load_recipe("transflower-small", [*TINY_DATA, *TINY["transflower-small"], "training.steps=2"])
    ckpt = train(recipe, out=str(tmp_path / "run"), quiet=True).checkpoint
    cold = load_recipe(
        "transflower-small",
        [*TINY_DATA, *TINY["transflower-small"], "training.steps=2", "compose.temperature=0", "compose.samples=2"],
    )
    hot = load_recipe(
        "transflower-small", [*TINY_DATA, *TINY["transflower-small"], "training.steps=2", "compose.samples=2", "seed=3"]
    )

    def run(recipe, out):
        files = compose(recipe, music=[str(demo_song)], checkpoint=str(ckpt), out_dir=str(tmp_path / out), quiet=True)
        return [np.load(f)[np.load(f).files[0]] for f in sorted(files)]

    a, b = run(cold, "a"), run(cold, "b")
    assert np.array_equal(a[0], b[0]) and np.allclose(a[0], a[1])  # samples agree at temperature 0
    h1, h2 = run(hot, "c"), run(hot, "d")
    assert np.array_equal(h1[0], h2[0])  # seeded
    assert not np.allclose(h1[0], h1[1])  # two samples per song differ at temperature 1
