"""TM2D's late fusion: where a text acts, and with what weight (section 3.4, Figure 3).

Over a text's span of ``n`` tokens the text weight rises along a half cosine from 0 to ``peak`` over the
first ``ramp`` of the span, holds ``peak``, and falls back over the last ``ramp``; it is 0 outside. Token
``i`` takes the curve's value at its centre, ``x = (i + 0.5) / n``:

    w(x) = peak · (1 - cos(π · min(x / ramp, (1 - x) / ramp, 1))) / 2

Spans come from the word-token stream: runs of consecutive tokens holding the same non-pad id row.
"""

from __future__ import annotations

import math

import torch


def fusion_weights(n: int, peak: float = 0.8, ramp: float = 0.2) -> torch.Tensor:
    """The text weight of each of a span's ``n`` tokens, ``(n,)`` float64."""
    centre = torch.arange(n, dtype=torch.float64) + 0.5  # x · n, exact: the curve is exactly symmetric
    edge = torch.clamp(torch.minimum(centre, n - centre) / (ramp * n), max=1.0)
    return peak * 0.5 * (1.0 - torch.cos(math.pi * edge))


def text_spans(rows: torch.Tensor) -> list[tuple[int, int]]:
    """``[start, end)`` of every run of identical non-pad rows in ``rows (N, W)`` (pad: all zeros)."""
    if len(rows) == 0:
        return []
    present = rows.ne(0).any(-1).tolist()
    changed = [True] + rows[1:].ne(rows[:-1]).any(-1).tolist()
    spans, start = [], None
    for i in range(len(rows)):
        if start is not None and (changed[i] or not present[i]):
            spans.append((start, i))
            start = None
        if start is None and present[i]:
            start = i
    if start is not None:
        spans.append((start, len(rows)))
    return spans
