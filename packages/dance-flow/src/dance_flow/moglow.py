"""MoGlow's context encoder: recent motion and music frames concatenated, then an LSTM.

At each of the last ``steps`` frame times ``tau`` of the window, the input is the concatenation of
the poses ``[tau - motion_frames, tau)`` and the music frames ``[tau - music_past, tau +
music_future)``; a stacked LSTM runs over those ``steps`` inputs (MoGlow's recurrence, truncated
to the window so that the encoder stays a pure function of it) and its last ``tokens`` outputs,
projected to ``dim``, condition the flow head.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from dance_core import Window


class MoGlowContext(nn.Module):
    """Windowed encoder: ``(B, mf+S-1, D)`` motion and ``{stream: (B, mp+S-1+mf', d)}`` -> ``(B, K, dim)``."""

    def __init__(self, config, motion_dim: int, cond_dims: Mapping[str, int]):
        super().__init__()
        s = config.steps
        self.window = Window(config.motion_frames + s - 1, config.music_past + s - 1, config.music_future)
        self.latent_tokens = config.tokens
        self.out_dim = config.dim
        self.streams = list(cond_dims)
        self.motion_frames = config.motion_frames
        self.music_frames = config.music_past + config.music_future
        width = config.motion_frames * motion_dim + self.music_frames * sum(cond_dims.values())
        self.lstm = nn.LSTM(
            width, config.hidden, config.layers, batch_first=True, dropout=config.dropout if config.layers > 1 else 0.0
        )
        self.out = nn.Linear(config.hidden, config.dim)

    def forward(self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """Encode one window."""
        parts = [_frames(motion, self.motion_frames)]
        parts += [_frames(cond[name], self.music_frames) for name in self.streams]
        out, _ = self.lstm(torch.cat(parts, dim=-1))
        return self.out(out[:, -self.latent_tokens :])


def _frames(x: torch.Tensor, size: int) -> torch.Tensor:
    """Sliding windows of ``size`` frames, flattened: ``(B, T, C) -> (B, T - size + 1, size * C)``."""
    return x.unfold(1, size, 1).transpose(2, 3).flatten(2)


def build(config, *, motion_dim: int, cond_dims: Mapping[str, int], **_: Any) -> MoGlowContext:
    """Build the ``moglow-context`` encoder."""
    return MoGlowContext(config, motion_dim, cond_dims)
