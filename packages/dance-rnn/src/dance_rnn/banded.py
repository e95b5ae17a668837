"""Banded (local) scaled dot-product attention in O(n·k) memory and time.

Frame ``i`` attends to frames ``j`` with ``|i - j| <= half``. Queries are cut into blocks of ``b``
frames; a block's keys are the block itself and ``r = ceil(half / b)`` blocks on each side, taken as
strided views of the padded keys, so the score tensor is ``(B, H, n/b, b, (2r+1) b)`` instead of
``(B, H, n, n)``. Query blocks are processed in groups so the transient scores stay bounded however
long the song. :func:`dense_banded_attention` is the quadratic reference used by the tests.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

#: score elements computed at once per group of query blocks (bounds the transient memory)
GROUP_ELEMENTS = 1 << 22


def _masked_softmax(scores: torch.Tensor, allowed: torch.Tensor, dropout: float, training: bool):
    # a finite fill keeps fully-masked rows (padding queries past the end) free of NaN gradients
    scores = scores.masked_fill(~allowed, torch.finfo(scores.dtype).min)
    weights = scores.softmax(dim=-1)
    return F.dropout(weights, dropout, training) if dropout else weights


def banded_attention(
    q: torch.Tensor,
    k: torch.Tensor,
    v: torch.Tensor,
    half: int,
    bias: torch.Tensor | None = None,
    block: int | None = None,
    dropout: float = 0.0,
    training: bool = False,
) -> torch.Tensor:
    """Local attention of ``q, k, v`` ``(B, H, n, d)`` over ``|i - j| <= half``; returns ``(B, H, n, d)``.

    ``bias`` ``(H, 2 half + 1)`` is added to the logit of offset ``j - i`` (index ``j - i + half``).
    """
    batch, heads, n, dim = q.shape
    if n == 0:
        return q.new_zeros(batch, heads, 0, v.shape[-1])
    b = min(block or max(half, 16), max(n, 1))
    r = math.ceil(half / b)
    nb = math.ceil(n / b)
    span = (2 * r + 1) * b
    q = F.pad(q, (0, 0, 0, nb * b - n)).view(batch, heads, nb, b, dim) / math.sqrt(dim)
    pad_keys = (0, 0, r * b, r * b + nb * b - n)
    k_win = F.pad(k, pad_keys).unfold(2, span, b)  # (B, H, nb, d, span), a strided view
    v_win = F.pad(v, pad_keys).unfold(2, span, b)
    offset = torch.arange(span, device=q.device)[None, :] - r * b - torch.arange(b, device=q.device)[:, None]
    in_band = offset.abs() <= half  # (b, span)
    if bias is not None:
        band_bias = bias[:, (offset + half).clamp(0, 2 * half)]  # (H, b, span)
    group = max(1, GROUP_ELEMENTS // max(1, batch * heads * b * span))
    out = []
    for g in range(0, nb, group):
        blocks = torch.arange(g, min(g + group, nb), device=q.device)
        key_pos = blocks[:, None] * b - r * b + torch.arange(span, device=q.device)[None, :]
        allowed = in_band[None] & ((key_pos >= 0) & (key_pos < n))[:, None, :]  # (G, b, span)
        scores = q[:, :, g : g + len(blocks)] @ k_win[:, :, g : g + len(blocks)]
        if bias is not None:
            scores = scores + band_bias[None, :, None]
        weights = _masked_softmax(scores, allowed, dropout, training)
        out.append(weights @ v_win[:, :, g : g + len(blocks)].transpose(-1, -2))
    return torch.cat(out, dim=2).reshape(batch, heads, nb * b, -1)[:, :, :n]


def dense_banded_attention(
    q: torch.Tensor, k: torch.Tensor, v: torch.Tensor, half: int, bias: torch.Tensor | None = None
) -> torch.Tensor:
    """The same attention as a dense ``n × n`` masked softmax (O(n²); a reference for tests)."""
    n = q.shape[2]
    pos = torch.arange(n, device=q.device)
    offset = pos[None, :] - pos[:, None]
    scores = q @ k.transpose(-1, -2) / math.sqrt(q.shape[-1])
    if bias is not None:
        scores = scores + bias[:, (offset + half).clamp(0, 2 * half)][None]
    scores = scores.masked_fill(offset.abs() > half, float("-inf"))
    return scores.softmax(dim=-1) @ v
