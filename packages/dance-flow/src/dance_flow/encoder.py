"""Transflower's context encoder: motion and music transformers, then a cross-modal transformer.

Every token carries its frame time relative to the step time ``t`` (motion ``[-mp, 0)``, music
``[-cp, cf)``, learned queries ``[0, K)``), so the relative position bias measures real time
offsets within and across modalities. A learned per-modality embedding tells the streams apart.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from dance_core import Window
from dance_flow.attention import Transformer


class TransflowerEncoder(nn.Module):
    """Windowed encoder: ``(B, mp, D)`` motion and ``{stream: (B, cp+cf, d)}`` -> ``(B, K, dim)``."""

    def __init__(self, config, motion_dim: int, cond_dims: Mapping[str, int]):
        super().__init__()
        if not cond_dims:
            raise ValueError("the transflower encoder needs at least one conditioning stream (features:)")
        self.window = Window(config.motion_past, config.cond_past, config.cond_future)
        self.latent_tokens = config.tokens
        self.out_dim = config.dim
        self.mode = config.latent
        self.streams = list(cond_dims)
        dim = config.dim
        self.motion_in = nn.Linear(motion_dim, dim)
        self.stream_in = nn.ModuleDict({n: nn.Linear(d, dim) for n, d in cond_dims.items()})
        self.motion_encoder = Transformer(dim, config.motion)
        self.stream_encoders = nn.ModuleDict({n: Transformer(dim, config.music) for n in self.streams})
        self.crossmodal = Transformer(dim, config.crossmodal)
        self.modality = nn.Parameter(torch.zeros(1 + len(self.streams), dim))
        nn.init.normal_(self.modality, std=0.02)
        prefix_room = config.motion_past + len(self.streams) * (config.cond_past + config.cond_future)
        if self.mode == "prefix" and config.tokens > prefix_room:
            raise ValueError(f"tokens ({config.tokens}) exceed the {prefix_room} encoded frames")
        self.queries = nn.Parameter(torch.randn(config.tokens, dim) * 0.02) if self.mode == "queries" else None
        self.register_buffer("motion_pos", torch.arange(-config.motion_past, 0), persistent=False)
        self.register_buffer("music_pos", torch.arange(-config.cond_past, config.cond_future), persistent=False)
        parts = [self.motion_pos] + [self.music_pos] * len(self.streams)
        if self.queries is not None:
            parts.append(torch.arange(config.tokens))
        self.register_buffer("joint_pos", torch.cat(parts), persistent=False)

    def forward(self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """Encode one window; the latent is the prefix or the learned queries' outputs."""
        tokens = [self.motion_encoder(self.motion_in(motion), self.motion_pos) + self.modality[0]]
        for i, name in enumerate(self.streams, start=1):
            x = self.stream_in[name](cond[name])
            tokens.append(self.stream_encoders[name](x, self.music_pos) + self.modality[i])
        if self.queries is not None:
            tokens.append(self.queries.unsqueeze(0).expand(tokens[0].shape[0], -1, -1))
        out = self.crossmodal(torch.cat(tokens, dim=1), self.joint_pos)
        k = self.latent_tokens
        return out[:, -k:] if self.queries is not None else out[:, :k]


def build(config, *, motion_dim: int, cond_dims: Mapping[str, int], **_: Any) -> TransflowerEncoder:
    """Build the ``transflower`` encoder."""
    return TransflowerEncoder(config, motion_dim, cond_dims)
