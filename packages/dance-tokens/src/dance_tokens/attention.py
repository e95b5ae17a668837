"""Multi-head attention with rotary positions and the masks TM2D's transformers use.

Positions are rotary (Su et al., 2021): queries and keys are rotated by their positions, so a score
depends on the offset between them only. With the masks' bounded spans (``context``, ``radius``) every
position sees what a position of a training segment saw, however long the song (the paper gives
neither its positional encoding nor spans; these are ours). Text cross-attention uses no positions.
Masks are boolean, ``True`` where a query may attend.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


def rotate(x: torch.Tensor, positions: torch.Tensor, base: float = 10000.0) -> torch.Tensor:
    """Rotary embedding of ``x (B, H, N, d)`` (d even) at integer ``positions (N,)``."""
    d = x.shape[-1]
    freq = base ** (-torch.arange(0, d, 2, device=x.device, dtype=torch.float32) / d)
    angle = positions.to(torch.float32)[:, None] * freq[None]
    cos, sin = angle.cos().to(x.dtype), angle.sin().to(x.dtype)
    even, odd = x[..., 0::2], x[..., 1::2]
    return torch.stack([even * cos - odd * sin, even * sin + odd * cos], dim=-1).flatten(-2)


def causal_mask(queries: torch.Tensor, keys: torch.Tensor, context: int | None) -> torch.Tensor:
    """``(Nq, Nk)``: key position ``<=`` query position and fewer than ``context`` positions back."""
    offset = queries[:, None] - keys[None, :]
    allowed = offset >= 0
    return allowed if context is None else allowed & (offset < context)


def band_mask(queries: torch.Tensor, keys: torch.Tensor, radius: int | None) -> torch.Tensor:
    """``(Nq, Nk)``: key position within ``radius`` of the query's (everything when ``radius`` is None)."""
    offset = queries[:, None] - keys[None, :]
    return torch.ones_like(offset, dtype=torch.bool) if radius is None else offset.abs() <= radius


class Attention(nn.Module):
    """Multi-head scaled dot-product attention of ``x`` over itself or over a ``memory``."""

    def __init__(self, dim: int, heads: int, dropout: float = 0.0):
        super().__init__()
        self.heads, self.dropout = heads, dropout
        self.query = nn.Linear(dim, dim)
        self.key_value = nn.Linear(dim, 2 * dim)
        self.out = nn.Linear(dim, dim)

    def _split(self, x: torch.Tensor) -> torch.Tensor:
        return x.view(x.shape[0], x.shape[1], self.heads, -1).transpose(1, 2)

    def forward(
        self,
        x: torch.Tensor,
        memory: torch.Tensor | None = None,
        mask: torch.Tensor | None = None,
        positions: torch.Tensor | None = None,
        memory_positions: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """``x (B, Nq, dim)`` attending to ``memory (B, Nk, dim)`` (default ``x``) under ``mask``
        (broadcastable to ``(B, heads, Nq, Nk)``); rotary when ``positions`` are given."""
        memory = x if memory is None else memory
        q = self._split(self.query(x))
        k, v = (self._split(t) for t in self.key_value(memory).chunk(2, dim=-1))
        if positions is not None:
            q = rotate(q, positions)
            k = rotate(k, positions if memory_positions is None else memory_positions)
        drop = self.dropout if self.training else 0.0
        out = F.scaled_dot_product_attention(q, k, v, attn_mask=mask, dropout_p=drop)
        return self.out(out.transpose(1, 2).reshape(x.shape[0], x.shape[1], -1))
