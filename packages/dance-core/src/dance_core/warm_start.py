"""``training.init``: a run that starts from a trained checkpoint's weights and normalization.

Fine-tuning a model on new data, or training a new part on top of parts trained before (a token
prior over a VQ-VAE kept as it was, a head on a trained encoder). The checkpoint is read before any
data is; the weights are copied once the model is built, before the first step; on ``--resume`` the
run's own checkpoint is read instead, as for any run.
"""

from __future__ import annotations

import numpy as np
import torch

from dance_core.checkpoint import Checkpoint, load_checkpoint
from dance_core.data.stats import NormStats
from dance_core.errors import CheckpointError
from dance_core.recipe.schema import Recipe


def init_checkpoint(recipe: Recipe) -> Checkpoint | None:
    """The checkpoint ``training.init`` names, read (one-line error when missing or not a checkpoint)."""
    spec = recipe.training.init
    if spec is None:
        return None
    ckpt = load_checkpoint(recipe.resolve_path(spec.checkpoint))
    for prefix in spec.weights:  # a misspelt prefix is found now; shapes once the model is built
        if not any(name.startswith(prefix) for name in ckpt.weights):
            raise CheckpointError(f"{ckpt.path}: training.init.weights: the checkpoint has no parameter starting "
                                  f"with {prefix!r}")
    return ckpt


def init_stats(ckpt: Checkpoint, fitted: NormStats) -> NormStats:
    """The checkpoint's statistics in place of ``fitted`` (the data's), which they must match in shape."""
    ours, theirs = fitted.to_arrays(), ckpt.stats.to_arrays()
    if set(ours) != set(theirs):
        missing = sorted(set(ours) ^ set(theirs))[0]
        raise CheckpointError(f"{ckpt.path}: training.init.stats: its statistics and the data's differ in "
                              f"streams ({missing}); set training.init.stats: false to fit them to the data")
    for key, value in ours.items():
        if np.shape(theirs[key]) != np.shape(value):
            raise CheckpointError(f"{ckpt.path}: training.init.stats: {key} has shape {np.shape(theirs[key])}, "
                                  f"the data's {np.shape(value)}")
    return ckpt.stats


def init_weights(model: torch.nn.Module, ckpt: Checkpoint, prefixes: list[str]) -> int:
    """Copy the parameters and buffers named by ``prefixes`` from the checkpoint; how many were copied.

    Each one must be in the checkpoint with the model's shape; a prefix naming nothing is an error."""
    own = model.state_dict()
    for prefix in prefixes:
        if not any(name.startswith(prefix) for name in own):
            raise CheckpointError(f"{ckpt.path}: training.init.weights: no parameter of the model starts with "
                                  f"{prefix!r}")
    chosen = [name for name in own if any(name.startswith(p) for p in prefixes)]
    for name in chosen:
        if name not in ckpt.weights:
            raise CheckpointError(f"{ckpt.path}: training.init.weights: the checkpoint has no {name}")
        if ckpt.weights[name].shape != own[name].shape:
            raise CheckpointError(f"{ckpt.path}: training.init.weights: {name} has shape "
                                  f"{tuple(ckpt.weights[name].shape)}, the model's {tuple(own[name].shape)}")
    model.load_state_dict({name: ckpt.weights[name] for name in chosen}, strict=False)
    return len(chosen)
