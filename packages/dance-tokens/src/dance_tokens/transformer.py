"""Transformer encoder and decoder stacks as TM2D describes them (section 3.3, Figure 3).

Post-norm blocks, as in the paper: attention, add, normalize, (cross-attention, add, normalize,)
feed-forward, add, normalize. An encoder block attends over its own sequence; a decoder block attends
causally over past inputs, then across to a memory (audio or text), then applies the feed-forward.
"""

from __future__ import annotations

import torch
from torch import nn

from dance_tokens.attention import Attention


class FeedForward(nn.Sequential):
    """``Linear -> ReLU -> Dropout -> Linear``."""

    def __init__(self, dim: int, hidden: int, dropout: float):
        super().__init__(nn.Linear(dim, hidden), nn.ReLU(), nn.Dropout(dropout), nn.Linear(hidden, dim))


class EncoderBlock(nn.Module):
    """Self-attention and feed-forward, each with a residual and a LayerNorm after it."""

    def __init__(self, dim: int, heads: int, ffn: int, dropout: float):
        super().__init__()
        self.attention = Attention(dim, heads, dropout)
        self.norm1 = nn.LayerNorm(dim)
        self.ff = FeedForward(dim, ffn, dropout)
        self.norm2 = nn.LayerNorm(dim)
        self.drop = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None, positions: torch.Tensor | None) -> torch.Tensor:
        """``(B, N, dim) -> (B, N, dim)``."""
        x = self.norm1(x + self.drop(self.attention(x, mask=mask, positions=positions)))
        return self.norm2(x + self.drop(self.ff(x)))


class DecoderBlock(nn.Module):
    """Masked self-attention, cross-attention to a memory, feed-forward; post-norm residuals."""

    def __init__(self, dim: int, heads: int, ffn: int, dropout: float):
        super().__init__()
        self.self_attention = Attention(dim, heads, dropout)
        self.norm1 = nn.LayerNorm(dim)
        self.cross_attention = Attention(dim, heads, dropout)
        self.norm2 = nn.LayerNorm(dim)
        self.ff = FeedForward(dim, ffn, dropout)
        self.norm3 = nn.LayerNorm(dim)
        self.drop = nn.Dropout(dropout)

    def forward(
        self,
        x: torch.Tensor,
        memory: torch.Tensor,
        self_mask: torch.Tensor,
        memory_mask: torch.Tensor | None,
        positions: torch.Tensor,
        memory_positions: torch.Tensor | None,
    ) -> torch.Tensor:
        """``(B, N, dim) -> (B, N, dim)``; rotary cross-attention when ``memory_positions`` are given."""
        x = self.norm1(x + self.drop(self.self_attention(x, mask=self_mask, positions=positions)))
        cross_pos = positions if memory_positions is not None else None
        y = self.cross_attention(x, memory, memory_mask, cross_pos, memory_positions)
        x = self.norm2(x + self.drop(y))
        return self.norm3(x + self.drop(self.ff(x)))


class Encoder(nn.Module):
    """A stack of :class:`EncoderBlock`."""

    def __init__(self, layers: int, dim: int, heads: int, ffn: int, dropout: float):
        super().__init__()
        self.blocks = nn.ModuleList(EncoderBlock(dim, heads, ffn, dropout) for _ in range(layers))

    def forward(
        self, x: torch.Tensor, mask: torch.Tensor | None = None, positions: torch.Tensor | None = None
    ) -> torch.Tensor:
        """``(B, N, dim) -> (B, N, dim)``."""
        for block in self.blocks:
            x = block(x, mask, positions)
        return x


class Decoder(nn.Module):
    """A stack of :class:`DecoderBlock` sharing one memory."""

    def __init__(self, layers: int, dim: int, heads: int, ffn: int, dropout: float):
        super().__init__()
        self.blocks = nn.ModuleList(DecoderBlock(dim, heads, ffn, dropout) for _ in range(layers))

    def forward(
        self,
        x: torch.Tensor,
        memory: torch.Tensor,
        self_mask: torch.Tensor,
        memory_mask: torch.Tensor | None,
        positions: torch.Tensor,
        memory_positions: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """``(B, N, dim) -> (B, N, dim)``: the final hidden states, before any projection."""
        for block in self.blocks:
            x = block(x, memory, self_mask, memory_mask, positions, memory_positions)
        return x
