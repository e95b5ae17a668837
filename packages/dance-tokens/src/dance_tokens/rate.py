"""Between the frame rate and the token rate: token ``j`` covers frames ``[t·j, t·j + t)``."""

from __future__ import annotations

import torch
import torch.nn.functional as F


def token_count(frames: int, t: int) -> int:
    """Tokens covering ``frames`` frames (the last one may cover fewer than ``t``)."""
    return -(-frames // t)


def to_tokens(x: torch.Tensor, t: int, how: str = "mean") -> torch.Tensor:
    """``(B, T, C) -> (B, ceil(T / t), C)``: the mean of each token's frames (of those present, for a
    last partial token), or its first frame (``how="first"``); ``how="stack"`` gives ``(B, N, t·C)``,
    the token's frames side by side in time order (a last partial token repeats its last frame)."""
    if how == "first":
        return x[:, ::t]
    if how == "stack":
        n = token_count(x.shape[1], t)
        padded = F.pad(x.transpose(1, 2), (0, n * t - x.shape[1]), mode="replicate").transpose(1, 2)
        return padded.reshape(x.shape[0], n, t * x.shape[2])
    return F.avg_pool1d(x.transpose(1, 2), t, t, ceil_mode=True).transpose(1, 2)


def to_frames(x: torch.Tensor, t: int, frames: int) -> torch.Tensor:
    """``(B, N, C) -> (B, frames, C)``: each token's vector repeated over its ``t`` frames."""
    return x.repeat_interleave(t, dim=1)[:, :frames]


def token_middles(frames: int, t: int, tokens: int) -> torch.Tensor:
    """The middle frame of each of ``tokens`` tokens, clipped to ``frames - 1``."""
    return torch.clamp(torch.arange(tokens) * t + t // 2, max=frames - 1)
