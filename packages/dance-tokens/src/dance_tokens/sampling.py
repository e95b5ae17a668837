"""Top-k sampling of tokens (TM2D samples among the k = 100 most likely; supplementary Table 5)."""

from __future__ import annotations

import torch


def sample_top_k(
    logits: torch.Tensor, k: int, temperature: float = 1.0, generator: torch.Generator | None = None
) -> torch.Tensor:
    """A token per row of ``logits (B, K)``: argmax at temperature 0, else drawn from the softmax of the
    ``k`` largest logits divided by ``temperature``. Draws exactly one uniform number per row (none at
    temperature 0), whatever the logits, so equal seeds stay in step across differing rows."""
    if temperature <= 0:
        return logits.argmax(-1)
    top, index = logits.float().topk(min(k, logits.shape[-1]), dim=-1)
    cdf = torch.softmax(top / temperature, dim=-1).cumsum(-1)
    device = generator.device if generator is not None else logits.device
    u = torch.rand(logits.shape[0], 1, generator=generator, device=device).to(cdf.device)
    pick = torch.searchsorted(cdf, u * cdf[:, -1:]).clamp(max=top.shape[-1] - 1)
    return index.gather(-1, pick).squeeze(-1)
