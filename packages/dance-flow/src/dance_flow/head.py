"""The normalizing-flow output head: exact likelihood of the next N frames given the latent."""

from __future__ import annotations

import math
from typing import Any

import torch
from torch import nn

from dance_core import TrainContext
from dance_flow.flow import FlowNet, base_distribution


class FlowHead(nn.Module):
    """Models ``p(x_t..x_{t+N-1} | h)`` with a flow; ``h`` is ``(B, N, d)`` (one token per frame,
    concatenated channel-wise inside every coupling). Loss: negative log-likelihood in bits/dim.
    Sampling draws through ``dance_core.draw_rows`` (the base distributions), so rows may carry their
    own random streams (``row_generators``: songs composed in one batch)."""

    #: noise is drawn per row group through dance_core.draw_rows (compose.batch_songs may batch songs)
    row_generators = True

    def __init__(self, config, motion_dim: int, latent_dim: int):
        super().__init__()
        self.residual = config.residual
        self.history_frames = 1 if config.residual else 0
        self.frames = config.frames
        self.keep = config.keep
        self.latent_tokens = config.frames
        self.motion_dim = motion_dim
        self.noise = config.noise
        self.correlation = config.sample_correlation
        self.flow = FlowNet(motion_dim, latent_dim, config.frames, config)
        self.base = base_distribution(config)

    def log_prob(self, x: torch.Tensor, latent: torch.Tensor) -> torch.Tensor:
        """Exact ``log p(x | latent)`` in nats per batch element, for ``x (B, N, D)``."""
        z, logdet = self.flow(x, latent)
        return self.base.log_prob(z) + logdet

    def sample(
        self, latent: torch.Tensor, temperature: float = 1.0, generator: torch.Generator | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Frames ``(B, N, D)`` drawn with the base noise scaled by ``temperature`` (0 gives the
        mode of the base mapped through the flow) and their exact ``log p(x | latent)``."""
        shape = (latent.shape[0], self.frames, self.motion_dim)
        z = self.base.sample(shape, temperature, generator, latent.device, latent.dtype)
        x, logdet = self.flow.reverse(z, latent)
        return x, self.base.log_prob(z) + logdet

    def loss(
        self, latent: torch.Tensor, target: torch.Tensor, history: torch.Tensor, ctx: TrainContext
    ) -> dict[str, torch.Tensor]:
        """Negative log-likelihood in bits per dimension (and nats per frame, for logs); in training
        the targets get Gaussian noise of std ``noise``."""
        target = target.float()
        if self.residual:
            target = target - history[:, -1:].float()
        if self.training and self.noise > 0:
            target = target + self.noise * torch.randn_like(target)
        with torch.autocast(latent.device.type, enabled=False):
            log_p = self.log_prob(target, latent.float())
        nll = -log_p.mean()
        bits = nll / (self.frames * self.motion_dim * math.log(2.0))
        return {"loss": bits, "nats_per_frame": (nll / self.frames).detach()}

    def init_state(self, batch: int, generator: torch.Generator | None = None, song: Any = None) -> dict | None:
        """The previous step's base noise when sampling is correlated; else no state."""
        return {"z": None} if self.correlation > 0 else None

    def step(self, latent, history, state, temperature: float, generator=None):
        """Sample the next ``frames`` frames (the fast path: no log-likelihood); with
        ``sample_correlation`` rho the base noise is ``rho * z_prev + sqrt(1 - rho^2) * new``."""
        with torch.autocast(latent.device.type, enabled=False):
            latent = latent.float()
            shape = (latent.shape[0], self.frames, self.motion_dim)
            z = self.base.sample(shape, temperature, generator, latent.device, latent.dtype)
            if state is not None:
                if state["z"] is not None:
                    z = self.correlation * state["z"] + math.sqrt(1.0 - self.correlation**2) * z
                state = {"z": z}
            frames = self.flow.invert(z, latent)
            return (frames + history[:, -1:].float() if self.residual else frames), state

    def finish(self, motion: torch.Tensor, state: Any) -> torch.Tensor:
        """Identity."""
        return motion


def build(
    config, *, motion_dim: int, latent_dim: int, latent_tokens: int | None = None, window=None, **_: Any
) -> FlowHead:
    """Build the ``flow`` head: one latent token per predicted frame, from a windowed encoder's
    ``latent_tokens`` or a song-level encoder's per-frame latent."""
    song_level = window is not None and window.song_level
    if latent_tokens is None and not song_level:
        raise ValueError("the flow head needs an encoder that gives latent tokens (or a per-frame latent)")
    return FlowHead(config, motion_dim, latent_dim)
