"""The bundled recipes: the small one learns and composes; the cross-breed with dance-flow composes."""

import numpy as np
import pytest
import torch

from dance_core.compose import compose
from dance_core.data.synthetic_beats import click_track
from dance_core.formats.wav import write_wav
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry
from dance_core.train import Trainer

TINY = [
    "data.dataset.songs=6",
    "data.dataset.seconds=8",
    "training.val_every=10000",
    "training.checkpoint_every=10000",
    "training.log_every=50",
]


def song(path, seconds=4.0, bpm=120.0, rate=16000):
    write_wav(path, click_track(np.arange(0.0, seconds, 60 / bpm), seconds, rate, np.random.default_rng(0)), rate)
    return str(path)


def test_recipes_are_registered():
    assert {"dancerevolution", "dancerevolution-small", "cross-breed-small"} <= set(get_registry().names("recipe"))


@pytest.mark.slow
def test_small_recipe_learns_synthetic_choreography_and_composes(tmp_path):
    # core's energy features instead of the recipe's librosa-438: the same learning, a third of the time
    recipe = load_recipe(
        "dancerevolution-small",
        [
            *TINY,
            "features.music=[{plugin: energy}]",
            "data.segment_frames=40",
            "training.batch_size=16",
            "training.steps=300",
            "model.encoder.dim=32",
            "model.encoder.ff_dim=64",
            "model.head.hidden=64",
            "training.lr_schedule={plugin: constant}",
            "training.optimizer.lr=3e-3",
            "training.schedules.auto_condition={plugin: auto-condition-linear, rate: 1.0, offset: 0, limit: 5}",
        ],
    )
    trainer = Trainer(recipe, tmp_path / "run", quiet=True)
    result = trainer.run()
    motion, _ = trainer.val_sampler.batch(0)
    mean_pose = motion[:, 1:].abs().mean().item()  # predicting the mean pose (0 when normalized)
    still = (motion[:, 1:] - motion[:, :-1]).abs().mean().item()  # repeating the previous frame
    assert result.last_loss < result.first_loss / 3
    assert result.val_loss < 0.5 * min(mean_pose, still)  # on held-out songs, with q = 5 of every 15 generated
    paths = compose(
        recipe,
        music=[song(tmp_path / "a.wav")],
        checkpoint=str(result.checkpoint),
        out_dir=str(tmp_path / "out"),
        quiet=True,
    )
    with np.load(paths[0]) as f:
        assert f["values"].shape == (80, 18) and np.isfinite(f["values"]).all()
        assert f["values"][20:].std(axis=0).mean() > 0.01  # it dances rather than freezing


@pytest.mark.slow
def test_cross_breed_local_attention_feeds_the_flow_head(tmp_path):
    pytest.importorskip("dance_flow")
    recipe = load_recipe("cross-breed-small", [*TINY, "training.steps=60", "data.segment_frames=30"])
    trainer = Trainer(recipe, tmp_path / "run", quiet=True)
    model = trainer.model
    assert model.window.song_level and model.head.frames == 3 and model.head.history_frames == 0
    shapes = []
    loss_fn = model.head.loss
    model.head.loss = lambda latent, target, history, ctx: (
        shapes.append((latent.shape, target.shape)) or loss_fn(latent, target, history, ctx)
    )
    result = trainer.run()
    # 16 segments of 30 frames, each encoded once and cut into ten aligned 3-frame windows for the flow
    assert shapes[0] == (torch.Size([160, 3, 64]), torch.Size([160, 3, 18]))
    assert result.last_loss < result.first_loss
    music = [song(tmp_path / "a.wav", 3.0), song(tmp_path / "b.wav", 2.0, bpm=100)]
    paths = compose(recipe, music=music, checkpoint=str(result.checkpoint), out_dir=str(tmp_path / "out"), quiet=True)
    assert sorted(p.name for p in paths) == ["a.npz", "b.npz"]
    with np.load(tmp_path / "out" / "b.npz") as f:
        assert f["values"].shape == (40, 18) and np.isfinite(f["values"]).all()


def test_past_motion_augmentation_is_refused_by_a_song_level_encoder(tmp_path):
    from dance_core.errors import RecipeError

    recipe = load_recipe("dancerevolution-small", [*TINY, "data.dataset.songs=2", "features.music=[{plugin: energy}]",
                                                   "training.augment.motion_noise=0.1"])
    with pytest.raises(RecipeError, match="training.augment: motion_noise"):
        Trainer(recipe, tmp_path, quiet=True)
