"""DanceRevolution's music encoder: a linear embedding, then post-LN transformer layers whose
self-attention is restricted to each frame's ``k`` nearest neighbours (see :mod:`dance_rnn.banded`).

A *song-level* encoder in core's contract: it sees no motion and the whole conditioning sequence
once, and returns one latent vector per frame.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from dance_core import Window
from dance_rnn.banded import banded_attention


def sinusoidal_positions(n: int, dim: int, device: torch.device | None = None) -> torch.Tensor:
    """The transformer's sine/cosine table ``(n, dim)`` for positions ``0..n-1``."""
    pos = torch.arange(n, dtype=torch.float32, device=device)[:, None]
    freq = torch.exp(torch.arange(0, dim, 2, dtype=torch.float32, device=device) * (-math.log(10000.0) / dim))
    table = torch.zeros(n, dim, device=device)
    table[:, 0::2] = torch.sin(pos * freq)
    table[:, 1::2] = torch.cos(pos * freq[: dim // 2])
    return table


class LocalSelfAttention(nn.Module):
    """Multi-head self-attention over ``|i - j| <= half``, optionally with a learned offset bias."""

    def __init__(
        self, dim: int, heads: int, head_dim: int, half: int, relative: bool, dropout: float, block: int | None
    ):
        super().__init__()
        self.heads, self.head_dim, self.half, self.block = heads, head_dim, half, block
        self.dropout = dropout
        self.qkv = nn.Linear(dim, 3 * heads * head_dim)
        self.proj = nn.Linear(heads * head_dim, dim)
        self.bias = nn.Parameter(torch.zeros(heads, 2 * half + 1)) if relative else None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, n, dim) -> (B, n, dim)``."""
        batch, n, _ = x.shape
        q, k, v = self.qkv(x).view(batch, n, 3, self.heads, self.head_dim).permute(2, 0, 3, 1, 4)
        out = banded_attention(q, k, v, self.half, self.bias, self.block, self.dropout, self.training)
        return self.proj(out.transpose(1, 2).reshape(batch, n, -1))


class EncoderLayer(nn.Module):
    """Local self-attention and a position-wise feed-forward, each with residual + LayerNorm."""

    def __init__(self, config, half: int):
        super().__init__()
        c = config
        self.attention = LocalSelfAttention(
            c.dim, c.heads, c.head_dim, half, c.position == "relative", c.dropout, c.block
        )
        self.norm1 = nn.LayerNorm(c.dim)
        self.ff = nn.Sequential(nn.Linear(c.dim, c.ff_dim), nn.ReLU(), nn.Linear(c.ff_dim, c.dim))
        self.norm2 = nn.LayerNorm(c.dim)
        self.drop = nn.Dropout(c.dropout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, n, dim) -> (B, n, dim)`` (post-LN, as in the paper's transformer)."""
        x = self.norm1(x + self.drop(self.attention(x)))
        return self.norm2(x + self.drop(self.ff(x)))


class LocalAttentionEncoder(nn.Module):
    """Song-level music encoder: ``{stream: (B, T, d_s)} -> (B, T, dim)``."""

    latent_tokens = None
    window = Window(motion_past=0, cond_past=None, cond_future=0)

    def __init__(self, config, streams: list[str], in_dim: int):
        super().__init__()
        self.streams = streams
        self.out_dim = config.dim
        self.half = config.k // 2
        self.sinusoidal = config.position == "sinusoidal"
        self.embed = nn.Linear(in_dim, config.dim)
        self.drop = nn.Dropout(config.dropout)
        self.layers = nn.ModuleList(EncoderLayer(config, self.half) for _ in range(config.layers))

    def forward(self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """Encode whole sequences (``motion`` is unused: the encoder sees music only)."""
        x = self.embed(torch.cat([cond[name] for name in self.streams], dim=-1))
        if self.sinusoidal:
            x = x + sinusoidal_positions(x.shape[1], x.shape[2], x.device).to(x.dtype)
        x = self.drop(x)
        for layer in self.layers:
            x = layer(x)
        return x


def build(config, *, cond_dims: Mapping[str, int], **_: Any) -> LocalAttentionEncoder:
    """Build the ``local-attention`` encoder over the chosen (or all) conditioning streams."""
    streams = list(config.streams) if config.streams else sorted(cond_dims)
    missing = [s for s in streams if s not in cond_dims]
    if missing or not streams:
        raise ValueError(
            f"streams: {', '.join(missing) or 'none'} not among the feature streams "
            f"({', '.join(sorted(cond_dims)) or 'none'})"
        )
    return LocalAttentionEncoder(config, streams, sum(cond_dims[s] for s in streams))
