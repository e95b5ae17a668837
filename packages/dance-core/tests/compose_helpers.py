"""Helpers shared by the composition tests: the tiny model, a click-track song writer and a sampling head plugin."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from dance_core import hookimpl
from dance_core.components.configs import RegressionHeadConfig
from dance_core.components.modules import RegressionHead
from dance_core.data.synthetic_beats import click_track
from dance_core.formats.wav import write_wav

#: recipe overrides of the tiny core-dance model the composition tests train and compose with
TINY = ["data.dataset.songs=3", "data.dataset.seconds=8", "training.steps=20", "training.batch_size=8",
        "training.val_every=20", "training.checkpoint_every=20", "training.log_every=10"]


def tiny_checkpoint(root: Path) -> str:
    """Train the tiny core-dance model under ``root / "run"``; its checkpoint's path."""
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    return str(train(load_recipe("core-dance", TINY), out=str(root / "run"), quiet=True).checkpoint)


def click_song(path: Path, seconds: float, bpm: float = 120.0, rate: int = 16000) -> str:
    """Write a click track of ``seconds`` at ``bpm`` to ``path`` (its noise seeded by the tempo); its path."""
    beats = np.arange(0.0, seconds, 60.0 / bpm)
    write_wav(path, click_track(beats, seconds, rate, np.random.default_rng(int(bpm))), rate)
    return str(path)


class NoisyHead(RegressionHead):
    """A sampling head: the regression plus noise drawn from compose's generator."""

    def step(self, latent, history, state, temperature, generator=None):
        pred, state = super().step(latent, history, state, temperature, generator)
        noise = torch.randn(pred.shape, generator=generator, device=pred.device, dtype=pred.dtype)
        return pred + 0.3 * temperature * noise, state


class NoisyPlugin:
    """Registers ``noisy-head`` (use with ``dance_core.testing.registered_plugin``)."""

    @hookimpl
    def register_heads(self, register):
        register("noisy-head", RegressionHeadConfig,
                 lambda c, *, motion_dim, latent_dim, **_: NoisyHead(c, motion_dim, latent_dim, None))
