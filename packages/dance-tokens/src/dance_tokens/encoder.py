"""TM2D's audio encoder as a song-level encoder (``tm2d-audio``).

The music streams are brought to the token rate (the mean of each token's ``t`` frames by default, so
a one-frame onset or beat peak is not skipped; ``pool: first`` samples every t-th frame; ``pool: stack``
lays the token's ``t`` frames side by side, so the frame a beat falls on is kept), embedded by a
linear layer and run through transformer encoder layers (section 3.3: "an embedded layer followed by
several transformer blocks"). Each token's vector is repeated over its ``t`` frames, so core's per-frame
slicing works; the ``tm2d`` head takes the token-rate vectors back as its audio memory.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from dance_core import Window
from dance_tokens.attention import band_mask
from dance_tokens.rate import to_frames, to_tokens
from dance_tokens.transformer import Encoder


class AudioEncoder(nn.Module):
    """``{stream: (B, T, C)} -> (B, T, dim)``, constant over each token's frames."""

    latent_tokens = None
    window = Window(motion_past=0, cond_past=None, cond_future=0)

    def __init__(self, config, streams: list[str], in_dim: int):
        super().__init__()
        c = config
        self.config, self.streams, self.out_dim = c, streams, c.dim
        self.embed = nn.Linear(in_dim, c.dim)
        self.transformer = Encoder(c.layers, c.dim, c.heads, c.ffn, c.dropout)

    def forward(self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor], start: int = 0) -> torch.Tensor:
        """The per-frame latent of the whole conditioning sequence (``motion`` is unused); ``start``: the song's
        token the sequence starts at (a window of the song, live), so its positions are the song's."""
        c = self.config
        music = torch.cat([cond[name] for name in self.streams], dim=-1)
        tokens = to_tokens(music, c.downsample, c.pool)
        positions = torch.arange(start, start + tokens.shape[1], device=music.device)
        mask = None if c.radius is None else band_mask(positions, positions, c.radius)
        hidden = self.transformer(self.embed(tokens), mask, positions)
        return to_frames(hidden, c.downsample, music.shape[1])

    def reach(self) -> int | None:
        """Tokens on either side of its own that a token's latent depends on (``radius`` per layer), or None
        when the attention is global (a token reads the whole song)."""
        c = self.config
        return None if c.radius is None else c.radius * c.layers


def build(config, *, cond_dims: Mapping[str, int], **_: Any) -> AudioEncoder:
    """Build ``tm2d-audio`` over every stream but ``ignore`` (sorted by name)."""
    streams = sorted(name for name in cond_dims if name not in config.ignore)
    if not streams:
        raise ValueError(f"no music stream to encode (streams: {', '.join(cond_dims) or 'none'}; "
                         f"ignored: {', '.join(config.ignore)})")
    width = sum(cond_dims[name] for name in streams)
    return AudioEncoder(config, streams, width * (config.downsample if config.pool == "stack" else 1))
