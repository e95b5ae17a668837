"""Dynamic auto-condition: the growth functions of q and the ground-truth/generated input pattern.

The paper alternates ``p`` ground-truth inputs with ``q`` self-generated ones and grows ``q`` with
the epoch ``t`` as const, ``floor(lambda t)``, ``floor(lambda t^2)`` or ``floor(lambda e^t)``. Each
growth function is a registered schedule ``(step, epoch, total_steps) -> q``; the recipe names one
under ``training.schedules.auto_condition`` and the LSTM head reads its value every step.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

ScheduleFn = Callable[[int, int, int], float]

#: added before flooring so that e.g. 0.29 * 100 = 28.999999999999996 counts as 29
_EPS = 1e-9


def _capped(value: float, limit: int | None) -> float:
    q = math.floor(value + _EPS)
    return float(q if limit is None else min(q, limit))


def build_const(config, **_: Any) -> ScheduleFn:
    """q = ``value`` at every epoch (static auto-condition)."""
    return lambda step, epoch, total: float(config.value)


def build_linear(config, **_: Any) -> ScheduleFn:
    """q = floor(lambda * t), t = epoch + offset (the paper's choice and the reference code's)."""
    return lambda step, epoch, total: _capped(config.rate * (epoch + config.offset), config.limit)


def build_quadratic(config, **_: Any) -> ScheduleFn:
    """q = floor(lambda * t^2)."""
    return lambda step, epoch, total: _capped(config.rate * (epoch + config.offset) ** 2, config.limit)


def build_exponential(config, **_: Any) -> ScheduleFn:
    """q = floor(lambda * e^t), capped at ``limit`` (computed in logs, so it never overflows)."""

    def value(step: int, epoch: int, total: int) -> float:
        t = epoch + config.offset
        log_q = math.log(config.rate) + t
        if log_q >= math.log(config.limit + 1):
            return float(config.limit)
        return _capped(math.exp(log_q), config.limit)

    return value


def ground_truth_inputs(length: int, p: int, q: int) -> list[bool]:
    """Which of ``length`` decoder inputs are ground truth: periods of ``p`` true, then ``q`` false.

    Input 0 (the frame before the first target) is always ground truth, as in the paper's
    ``{y1..yp, ŷ(p+1)..ŷ(p+q), y(p+q+1)..}``; the reference code starts with the q generated ones.
    """
    if p < 1 or q < 0:
        raise ValueError(f"auto-condition needs p >= 1 and q >= 0, got p={p}, q={q}")
    return [i % (p + q) < p for i in range(length)]
