"""Transformer encoder stacks with a T5-style relative position bias, learned per head.

Positions are integer frame times, so the bias between two tokens depends only on their time
difference (translation invariant) and the same module serves any window length.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn


def relative_buckets(offset: torch.Tensor, buckets: int, max_distance: int) -> torch.Tensor:
    """Bucket index of each signed offset (key time minus query time).

    Half the buckets hold keys before the query, half keys at or after it. Within a half, small
    distances get one bucket each; larger ones share buckets spaced logarithmically up to
    ``max_distance``, beyond which all distances fall in the last bucket.
    """
    half = max(buckets // 2, 2)
    side = (offset > 0).long() * half
    distance = offset.abs()
    exact = max(half // 2, 1)
    scaled = torch.log(distance.clamp(min=1).float() / exact) / math.log(max(max_distance / exact, 1.0 + 1e-6))
    far = exact + (scaled * (half - exact)).long()
    far = far.clamp(max=half - 1)
    return side + torch.where(distance < exact, distance, far)


class RelativeBias(nn.Module):
    """One learned scalar per (bucket, head), added to the attention logits of every layer."""

    def __init__(self, heads: int, buckets: int = 32, max_distance: int = 128):
        super().__init__()
        self.heads = heads
        self.buckets = max(buckets, 4)
        self.max_distance = max_distance
        self.table = nn.Embedding(2 * max(self.buckets // 2, 2), heads)
        nn.init.normal_(self.table.weight, std=0.02)
        self._cache: tuple[torch.Tensor, torch.Tensor] | None = None
        self._bias_cache: tuple[torch.Tensor, tuple, torch.Tensor] | None = None

    def index(self, positions: torch.Tensor) -> torch.Tensor:
        """Bucket indices ``(L, L)`` for integer positions ``(L,)`` (cached for repeated calls). An index
        computed under ``torch.inference_mode`` (generation) is an inference tensor that autograd may not
        save, so outside inference mode it is computed again (and that normal tensor cached, which
        inference mode may use)."""
        cached = self._cache
        if (
            cached is not None
            and not (cached[1].is_inference() and not torch.is_inference_mode_enabled())
            and cached[0].shape == positions.shape
            and cached[0].device == positions.device
            and torch.equal(cached[0], positions)
        ):
            return cached[1]
        offset = positions[None, :] - positions[:, None]
        idx = relative_buckets(offset, self.buckets, self.max_distance)
        self._cache = (positions.clone(), idx)
        return idx

    def forward(self, positions: torch.Tensor) -> torch.Tensor:
        """Bias ``(1, heads, L, L)`` (contiguous) for query/key positions ``(L,)``. Without
        gradients (evaluation, generation) the bias itself is cached, keyed by the positions and
        the table's version counter, so a sliding-window loop looks it up once per window length."""
        weight = self.table.weight
        if torch.is_grad_enabled() and weight.requires_grad:
            return self.table(self.index(positions)).permute(2, 0, 1).unsqueeze(0).contiguous()
        key = (positions._version, weight._version, weight.data_ptr(), weight.dtype)
        hit = self._bias_cache
        if (hit is not None and hit[0] is positions and hit[1] == key
                and not (hit[2].is_inference() and not torch.is_inference_mode_enabled())):
            return hit[2]
        bias = self.table(self.index(positions)).permute(2, 0, 1).unsqueeze(0).contiguous().detach()
        self._bias_cache = (positions, key, bias)
        return bias


class EncoderLayer(nn.Module):
    """Self-attention and a feed-forward block, each residual, with pre- or post-LayerNorm."""

    def __init__(self, dim: int, heads: int, ffn: int, dropout: float, norm: str):
        super().__init__()
        self.heads = heads
        self.pre = norm == "pre"
        self.qkv = nn.Linear(dim, 3 * dim)
        self.proj = nn.Linear(dim, dim)
        self.ff = nn.Sequential(nn.Linear(dim, ffn), nn.ReLU(), nn.Dropout(dropout), nn.Linear(ffn, dim))
        self.norm1 = nn.LayerNorm(dim)
        self.norm2 = nn.LayerNorm(dim)
        self.drop = nn.Dropout(dropout)
        self.attn_dropout = dropout

    def attend(self, x: torch.Tensor, bias: torch.Tensor | None) -> torch.Tensor:
        """Multi-head self-attention of ``(B, L, dim)`` with an additive logit bias."""
        b, length, dim = x.shape
        qkv = F.linear(x, self.qkv.weight, self.qkv.bias).view(b, length, 3, self.heads, dim // self.heads)
        q, k, v = qkv.permute(2, 0, 3, 1, 4)
        if bias is not None and bias.dtype != q.dtype:
            bias = bias.to(q.dtype)
        p = self.attn_dropout if self.training else 0.0
        out = F.scaled_dot_product_attention(q, k, v, attn_mask=bias, dropout_p=p)
        return F.linear(out.transpose(1, 2).reshape(b, length, dim), self.proj.weight, self.proj.bias)

    def forward(self, x: torch.Tensor, bias: torch.Tensor | None) -> torch.Tensor:
        """One layer."""
        if not self.training:
            return self._infer(x, bias)
        if self.pre:
            x = x + self.drop(self.attend(self.norm1(x), bias))
            return x + self.drop(self.ff(self.norm2(x)))
        x = self.norm1(x + self.drop(self.attend(x, bias)))
        return self.norm2(x + self.drop(self.ff(x)))


    def _infer(self, x: torch.Tensor, bias: torch.Tensor | None) -> torch.Tensor:
        """The same layer in evaluation, through functional calls (no dropout, fewer module calls:
        the sliding-window generation loop runs it at every step on a handful of tokens)."""
        n1, n2, (fc1, _, _, fc2) = self.norm1, self.norm2, self.ff
        if self.pre:
            y = F.layer_norm(x, n1.normalized_shape, n1.weight, n1.bias, n1.eps)
            x = x + self.attend(y, bias)
            y = F.layer_norm(x, n2.normalized_shape, n2.weight, n2.bias, n2.eps)
            return x + F.linear(F.relu(F.linear(y, fc1.weight, fc1.bias)), fc2.weight, fc2.bias)
        x = F.layer_norm(x + self.attend(x, bias), n1.normalized_shape, n1.weight, n1.bias, n1.eps)
        y = F.linear(F.relu(F.linear(x, fc1.weight, fc1.bias)), fc2.weight, fc2.bias)
        return F.layer_norm(x + y, n2.normalized_shape, n2.weight, n2.bias, n2.eps)


class Transformer(nn.Module):
    """A stack of encoder layers sharing one relative position bias (or none)."""

    def __init__(self, dim: int, config):
        super().__init__()
        ffn = config.ffn or dim
        self.layers = nn.ModuleList(
            EncoderLayer(dim, config.heads, ffn, config.dropout, config.norm) for _ in range(config.layers)
        )
        relative = config.positions == "relative" and config.layers > 0
        buckets = getattr(config, "buckets", 32)
        max_distance = getattr(config, "max_distance", 128)
        self.bias = RelativeBias(config.heads, buckets, max_distance) if relative else None
        self.final = nn.LayerNorm(dim) if config.norm == "pre" and config.layers > 0 else nn.Identity()
        self.identity_final = isinstance(self.final, nn.Identity)

    def forward(self, x: torch.Tensor, positions: torch.Tensor) -> torch.Tensor:
        """``(B, L, dim)`` tokens at integer times ``positions (L,)`` -> ``(B, L, dim)``."""
        bias = self.bias(positions) if self.bias is not None else None
        for layer in self.layers:
            x = layer(x, bias)
        return x if self.identity_final else self.final(x)
