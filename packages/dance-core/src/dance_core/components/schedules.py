"""Core's schedules: multipliers of the learning rate as a function of the step."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

ScheduleFn = Callable[[int, int, int], float]


def _warm(step: int, warmup: int) -> float:
    return min(1.0, (step + 1) / warmup) if warmup else 1.0


def build_constant(config, **_: Any) -> ScheduleFn:
    """Always ``value``."""
    return lambda step, epoch, total: config.value


def build_cosine(config, **_: Any) -> ScheduleFn:
    """Linear warm-up to 1, then cosine decay to ``floor`` at the last step."""

    def value(step: int, epoch: int, total: int) -> float:
        if step < config.warmup:
            return _warm(step, config.warmup)
        span = max(1, total - config.warmup)
        progress = min(1.0, (step - config.warmup) / span)
        return config.floor + (1 - config.floor) * 0.5 * (1 + math.cos(math.pi * progress))

    return value


def build_multistep(config, **_: Any) -> ScheduleFn:
    """Warm-up, then ``gamma`` to the power of the milestones passed (Transflower's LR decay)."""
    milestones = sorted(config.milestones)

    def value(step: int, epoch: int, total: int) -> float:
        passed = sum(step >= m for m in milestones)
        return _warm(step, config.warmup) * config.gamma**passed

    return value
