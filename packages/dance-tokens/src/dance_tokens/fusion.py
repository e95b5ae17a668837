"""TM2D's late fusion: where a text acts, and with what weight (section 3.4, Figure 3).

Over a text's span of ``n`` tokens the text weight rises along a half cosine from 0 to ``peak`` over the
first ``ramp`` of the span, holds ``peak``, and falls back over the last ``ramp``; it is 0 outside. Token
``i`` takes the curve's value at its centre, ``x = (i + 0.5) / n``:

    w(x) = peak · (1 - cos(π · min(x / ramp, (1 - x) / ramp, 1))) / 2

A span acts over the run of tokens whose middle frame it is in force at (core's span table gives the
span in force per frame, ``TextSpans.index``): two adjacent spans are two runs, each with its own rise
and fall, even when their sentences are the same; a span interrupted by a later one resumes as a new run.
"""

from __future__ import annotations

import math

import torch


def fusion_weights(n: int, peak: float = 0.8, ramp: float = 0.2) -> torch.Tensor:
    """The text weight of each of a span's ``n`` tokens, ``(n,)`` float64."""
    centre = torch.arange(n, dtype=torch.float64) + 0.5  # x · n, exact: the curve is exactly symmetric
    edge = torch.clamp(torch.minimum(centre, n - centre) / (ramp * n), max=1.0)
    return peak * 0.5 * (1.0 - torch.cos(math.pi * edge))


def span_runs(index: torch.Tensor) -> list[tuple[int, int, int]]:
    """``(start, end, span)`` of every run ``[start, end)`` of one span in ``index (N,)`` (-1: none)."""
    values = index.tolist()
    runs, start = [], 0
    for i in range(1, len(values) + 1):
        if i == len(values) or values[i] != values[start]:
            if values[start] >= 0:
                runs.append((start, i, values[start]))
            start = i
    return runs
