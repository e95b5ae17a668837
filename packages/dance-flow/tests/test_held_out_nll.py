"""Held-out NLL (dance_core.likelihood) of the flow head: finite, deterministic, lower after
training than before on songs the model never saw; a regression head has none (n/a)."""

from __future__ import annotations

import math

import pytest

from dance_core.contexts import DatasetContext
from dance_core.likelihood import held_out_nll
from dance_core.recipe import load_recipe
from dance_core.train import train

TINY_DATA = ["data.dataset.songs=3", "data.dataset.seconds=8", "training.val_every=1000",
             "features.music=[{plugin: energy}]", "compose.formats=[npz]"]
WINDOW = ["model.encoder.motion_past=12", "model.encoder.cond_past=12", "model.encoder.cond_future=4"]
TINY = {
    "transflower-small": WINDOW,
    "aichoreographer": [*WINDOW, "model.encoder.dim=16", "model.encoder.motion={layers: 1, heads: 2}",
                        "model.encoder.music={layers: 1, heads: 2}", "model.encoder.crossmodal={layers: 1, heads: 2}",
                        "model.head.hidden=16", "training.batch_size=8"],
}
SETS = [*TINY_DATA, "data.val_fraction=0.34", "training.batch_size=16", "training.optimizer.lr=2e-3"]


def held_out_songs(name: str, sets: list[str], first: int, last: int):
    """Songs ``first..last-1`` of recipe ``name``'s generator (the model trains on songs 0-2)."""
    recipe = load_recipe(name, [*sets, f"data.dataset.songs={last}"])
    dataset = recipe.data.dataset.build(DatasetContext(fps=recipe.fps, seed=recipe.seed, root=recipe.folder))
    return dataset.clips()[first:last]


@pytest.mark.slow
def test_the_flows_held_out_nll_falls_with_training_and_regression_has_none(tmp_path):
    sets = [*SETS, *TINY["transflower-small"]]
    before = load_recipe("transflower-small", [*sets, "training.steps=1"])
    after = load_recipe("transflower-small", [*sets, "training.steps=60"])
    songs = held_out_songs("transflower-small", sets, 3, 5)
    untrained = train(before, out=str(tmp_path / "a"), quiet=True).checkpoint
    trained = train(after, out=str(tmp_path / "b"), quiet=True).checkpoint
    nll0 = held_out_nll(before, untrained, songs, batches=3, batch_size=8)
    nll1 = held_out_nll(after, trained, songs, batches=3, batch_size=8)
    assert math.isfinite(nll0) and math.isfinite(nll1)
    assert nll1 == held_out_nll(after, trained, songs, batches=3, batch_size=8)  # fixed batches
    # nats per frame of the standardized representation (~70 channels): training lowers it a lot
    assert nll1 < nll0 - 20.0

    small = [*TINY_DATA, *TINY["aichoreographer"]]
    regression = load_recipe("aichoreographer", [*small, "training.steps=1"])
    ckpt = train(regression, out=str(tmp_path / "c"), quiet=True).checkpoint
    songs = held_out_songs("aichoreographer", small, 3, 4)
    assert held_out_nll(regression, ckpt, songs, batches=1, batch_size=4) is None
