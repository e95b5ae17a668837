"""The bundled recipes: tm2d at the paper's sizes builds; tm2d-small (shrunk) trains both stages through
core's Trainer, learns, and composes through core's compose with and without a text span."""

from pathlib import Path

import numpy as np
import pytest
import torch

import dance_tokens.plugin
from dance_core.compose import compose
from dance_core.data.synthetic_beats import click_track
from dance_core.formats.wav import write_wav
from dance_core.recipe import load_recipe
from dance_core.recipe.schema import TextSpec
from dance_core.train import Trainer

TOKENIZER_STEPS = 300
VOCAB = Path(dance_tokens.plugin.RECIPES) / "tm2d-vocab.txt"


def text_feature(max_words):
    """The recipes' word-tokens with the bundled vocabulary by absolute path (a recipe's relative path is
    read from the working directory)."""
    return f"features.text=[{{plugin: word-tokens, vocab: {VOCAB}, max_words: {max_words}}}]"


SHRUNK = [
    text_feature(16),
    "data.dataset.datasets.0.songs=4",
    "data.dataset.datasets.0.seconds=10",
    "data.dataset.datasets.1.clips=18",
    "data.dataset.datasets.1.seconds=[4.5, 6]",
    "data.val_fraction=0.2",
    "data.segment_frames=64",
    "model.encoder={plugin: tm2d-audio, dim: 32, layers: 1, heads: 4, ffn: 64, dropout: 0.0, radius: 4}",
    "model.head.tokenizer={codes: 64, code_dim: 16, width: 48, crop: 64, recon: smooth-l1, restart_after: 10}",
    "model.head.prior={dim: 32, layers: 2, text_layers: 1, heads: 4, ffn: 64, dropout: 0.0, vocab_size: 96,"
    " context: 8, radius: 4}",
    "training.val_every=100000",
    "training.checkpoint_every=100000",
    "training.log_every=100000",
]


def stages(tokenizer, prior):
    return (f"training.stages=[{{name: tokenizer, steps: {tokenizer}, trainable: [head.tokenizer.], lr: 3.0e-3,"
            f" batch_size: 32}}, {{name: prior, steps: {prior}, trainable: [encoder., head.prior.], lr: 2.0e-3,"
            " batch_size: 16}]")


def song(path, seconds=6.0, bpm=120.0, rate=16000):
    write_wav(path, click_track(np.arange(0.0, seconds, 60 / bpm), seconds, rate, np.random.default_rng(0)), rate)
    return str(path)


def test_recipes_are_registered_and_tm2d_has_the_papers_size(registry):
    assert {"tm2d", "tm2d-small"} <= set(registry.names("recipe"))
    from dance_core.data.features import FeatureStack
    from dance_core.model import build_model

    recipe = load_recipe("tm2d", [text_feature(84)])
    stack = FeatureStack(recipe)
    assert stack.dims() == {"music": 438, "text": 84}
    model = build_model(recipe, 75, stack.dims())
    params = sum(p.numel() for p in model.parameters())
    assert 70e6 < params < 85e6  # the paper: 72 M
    assert len(model.encoder.transformer.blocks) == len(model.head.prior.decoder.blocks) == 6
    assert len(model.head.prior.text.transformer.blocks) == 6


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """tm2d-small shrunk, both stages through core's Trainer: (recipe, trainer, result)."""
    import dance_tokens.plugin as plugin
    from dance_core.testing import registered_plugin

    root = tmp_path_factory.mktemp("tm2d-small")
    with registered_plugin(plugin, "tokens"):
        recipe = load_recipe("tm2d-small", [*SHRUNK, stages(TOKENIZER_STEPS, 300)])
        trainer = Trainer(recipe, root / "run", quiet=True)
        tokenizer = trainer.run(stop_at=TOKENIZER_STEPS)
        held_out = vq_on_held_out(trainer)
        result = trainer.run(resume=True)
        yield recipe, trainer, tokenizer, held_out, result, root


def vq_on_held_out(trainer):
    """(VQ-VAE L1, mean-pose L1, codebook usage) on validation segments (songs and clips never trained on)."""
    model = trainer.model.eval()
    with torch.no_grad():
        motion, _ = trainer.val_sampler.batch(0, "cpu", 64)
        recon, q = model.head.tokenizer(motion)
    model.train()
    return float((recon - motion).abs().mean()), float(motion.abs().mean()), float(q.usage)


@pytest.mark.slow
def test_tokenizer_reconstructs_held_out_motion_with_a_used_codebook(trained):
    _, _, tokenizer, (recon, mean_pose, usage), _, _ = trained
    assert tokenizer.steps == TOKENIZER_STEPS
    assert recon < 0.75 * mean_pose  # the mean pose is 0 in normalized units
    assert usage > 0.25  # over a quarter of the 64 codes in one validation batch


@pytest.mark.slow
def test_prior_stage_learns_tokens_of_both_corpora(trained):
    _, trainer, _, _, result, _ = trained
    model = trainer.model.eval()
    with torch.no_grad():
        batch = trainer.sampler.draw(0, "cpu", 64)
        out = model.training_loss(batch.motion, batch.streams, trainer._context(result.steps, trainer.stages[1]),
                                  spans=batch.spans)
    model.train()
    assert "ce_music" in out and "ce_text" in out  # both corpora in one batch
    assert float(out["ce_music"]) < 0.6 * np.log(64) and float(out["ce_text"]) < 0.6 * np.log(64)


@pytest.mark.slow
def test_composes_music_only_and_with_a_text_span(trained, tmp_path):
    recipe, _, _, _, result, root = trained
    music = song(tmp_path / "song.wav")

    def dance(*texts, name):
        r = recipe.model_copy(update={"compose": recipe.compose.model_copy(update={
            "texts": list(texts), "formats": ["npz"], "ground": False, "beat_align": False})})
        [path] = compose(r, music=[music], checkpoint=str(result.checkpoint), out_dir=str(tmp_path / name),
                         quiet=True)
        with np.load(path) as f:
            return f["values"]

    plain = dance(name="plain")
    clapped = dance(TextSpec.parse("3-5: someone claps their hands"), name="clap")
    assert plain.shape == clapped.shape == (180, plain.shape[1]) and np.isfinite(clapped).all()
    # the span starts at frame 90 = token 11.25: token 11 is the first one whose middle frame is in it
    model = trained[1].model.head.tokenizer
    boundary = model.first_frame_reached(11)
    np.testing.assert_array_equal(clapped[:boundary], plain[:boundary])
    assert not np.allclose(clapped[90:150], plain[90:150])
