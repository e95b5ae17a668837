"""What each rank runs in test_distributed.py (a module of its own: spawned ranks import it by name)."""

from __future__ import annotations

import hashlib
import math

import torch

from dance_core import hookimpl
from dance_core.components.configs import RegressionHeadConfig
from dance_core.components.modules import RegressionHead
from dance_core.recipe import load_recipe

TINY = [
    "data.dataset.songs=4",
    "data.dataset.seconds=6",
    "training.steps=40",
    "training.val_every=20",
    "training.checkpoint_every=20",
    "training.log_every=10",
    "model.conditioners.music.dropout=0.0",
]


def tiny(*extra: str):
    """core-synthetic shrunk as in conftest.py (no dropout: ranks draw their own masks)."""
    return load_recipe("core-synthetic", [*TINY, *extra])


def digest(model: torch.nn.Module) -> str:
    """SHA-256 of every weight's bytes."""
    h = hashlib.sha256()
    for name, value in sorted(model.state_dict().items()):
        h.update(name.encode())
        h.update(value.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()


class NanOnRankHead(RegressionHead):
    """A regression head whose loss is NaN from step 25 on rank 1 only."""

    def loss(self, latent, target, history, ctx):
        out = super().loss(latent, target, history, ctx)
        if ctx.step >= 25 and torch.distributed.get_rank() == 1:
            out["loss"] = out["loss"] * math.nan
        return out


class NanOnRankPlugin:
    @hookimpl
    def register_heads(self, register):
        register("nan-on-rank", RegressionHeadConfig,
                 lambda c, *, motion_dim, latent_dim, **_: NanOnRankHead(c, motion_dim, latent_dim, None))


def session(root: str, batch: int) -> dict:
    """On each rank: a whole run (A), a run stopped at step 20 (B), a run whose loss turns NaN on
    rank 1 (C), a run into a folder another live process has locked (D); what each gave (an error as
    its type and message)."""
    from dance_core import distributed
    from dance_core.testing import registered_plugin
    from dance_core.train import Trainer, train

    out: dict = {}
    with distributed.session() as ranks:
        trainer = Trainer(tiny(f"training.batch_size={batch}"), _path(root, "a"), quiet=True)
        result = trainer.run()
        out["a"] = (result.steps, result.last_loss, result.val_loss, digest(trainer.model), ranks.world)
        out["b"] = train(tiny(f"training.batch_size={batch}"), out=f"{root}/b", quiet=True, stop_at=20).steps
        with registered_plugin(NanOnRankPlugin(), "nan-on-rank"):
            try:
                train(tiny(f"training.batch_size={batch}", "model.head.plugin=nan-on-rank"), out=f"{root}/c",
                      quiet=True)
                out["c"] = None
            except Exception as exc:
                out["c"] = (type(exc).__name__, str(exc))
        try:
            train(tiny(f"training.batch_size={batch}"), out=f"{root}/d", quiet=True)
            out["d"] = None
        except Exception as exc:
            out["d"] = str(exc)
    return out


def _path(root: str, name: str):
    from pathlib import Path

    return Path(root) / name
