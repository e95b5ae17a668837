"""Core's torch components: an MLP conditioner, a windowed MLP encoder, a regression head."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from dance_core.protocols import TrainContext, Window


def mlp(sizes: list[int], dropout: float = 0.0) -> nn.Sequential:
    """Linear layers with GELU (and dropout) between them."""
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(nn.GELU())
            if dropout:
                layers.append(nn.Dropout(dropout))
    return nn.Sequential(*layers)


class MLPConditioner(nn.Module):
    """Per-frame MLP over one feature stream."""

    def __init__(self, in_dim: int, dim: int, layers: int, dropout: float):
        super().__init__()
        self.out_dim = dim
        self.net = mlp([in_dim] + [dim] * layers, dropout)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        """``(B, T, in_dim) -> (B, T, dim)``."""
        return self.net(features)


def build_mlp_conditioner(config, *, in_dim: int, **_: Any) -> MLPConditioner:
    """Build the ``mlp`` conditioner."""
    return MLPConditioner(in_dim, config.dim, config.layers, config.dropout)


class WindowMLP(nn.Module):
    """Flattens the motion and conditioning windows and maps them to ``tokens`` latent vectors."""

    def __init__(self, config, motion_dim: int, cond_dims: Mapping[str, int]):
        super().__init__()
        self.window = Window(config.motion_past, config.cond_past, config.cond_future)
        self.latent_tokens = config.tokens
        self.out_dim = config.dim
        self.streams = list(cond_dims)
        cond_frames = config.cond_past + config.cond_future
        flat = config.motion_past * motion_dim + cond_frames * sum(cond_dims.values())
        if flat == 0:
            raise ValueError("window-mlp sees nothing: give motion_past or cond_past/cond_future")
        sizes = [flat] + [config.hidden] * config.layers + [config.tokens * config.dim]
        self.net = mlp(sizes, config.dropout)

    def forward(self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """``(B, mp, D)`` motion and ``(B, cp+cf, d)`` streams -> ``(B, tokens, dim)``."""
        parts = [cond[name].flatten(1) for name in self.streams]
        if motion is not None and motion.shape[1]:
            parts.insert(0, motion.flatten(1))
        out = self.net(torch.cat(parts, dim=1))
        return out.view(out.shape[0], self.latent_tokens, self.out_dim)


def build_window_mlp(config, *, motion_dim: int, cond_dims: Mapping[str, int], **_: Any) -> WindowMLP:
    """Build the ``window-mlp`` encoder."""
    return WindowMLP(config, motion_dim, cond_dims)


class RegressionHead(nn.Module):
    """Deterministic frames from the latent, trained with L1 or L2 (AI Choreographer's head)."""

    history_frames = 0
    #: draws no noise, so rows of several songs may share a batch (compose.batch_songs)
    row_generators = True
    latent_tokens = None

    def __init__(
        self, config, motion_dim: int, latent_dim: int, latent_tokens: int | None, aligned: bool = False
    ):
        super().__init__()
        self.frames = config.frames
        self.keep = config.keep or config.frames
        self.motion_dim = motion_dim
        self.loss_kind = config.loss
        self.aligned = aligned  # a song-level encoder's per-frame latent: one output frame per latent frame
        tokens = latent_tokens or config.frames
        self.per_token = aligned or tokens == config.frames
        width = latent_dim if self.per_token else latent_dim * tokens
        out = motion_dim if self.per_token else motion_dim * config.frames
        self.net = mlp([width, config.hidden, out])

    def predict(self, latent: torch.Tensor) -> torch.Tensor:
        """``(B, K, d) -> (B, frames, D)``; aligned latents ``(B, T, d) -> (B, T, D)``."""
        if self.aligned:
            return self.net(latent)
        if self.per_token:
            return self.net(latent[:, : self.frames])
        return self.net(latent.flatten(1)).view(latent.shape[0], self.frames, self.motion_dim)

    def loss(self, latent, target, history, ctx: TrainContext) -> dict[str, torch.Tensor]:
        """Mean absolute (l1) or squared (l2) error of the predicted frames."""
        pred = self.predict(latent)
        err = (pred - target).abs() if self.loss_kind == "l1" else (pred - target).square()
        return {"loss": err.mean()}

    def init_state(self, batch: int, generator=None, song=None) -> None:
        """No state."""
        return None

    def step(self, latent, history, state, temperature, generator=None):
        """The predicted frames (temperature has no effect on a deterministic head)."""
        return self.predict(latent), state

    def finish(self, motion: torch.Tensor, state) -> torch.Tensor:
        """Identity."""
        return motion


def build_regression_head(
    config, *, motion_dim: int, latent_dim: int, latent_tokens: int | None = None, window: Window | None = None,
    **_: Any,
) -> RegressionHead:
    """Build the ``regression`` head (frame-aligned after a song-level encoder)."""
    aligned = window is not None and window.song_level
    return RegressionHead(config, motion_dim, latent_dim, latent_tokens, aligned)
