"""Where a run is in its stages: the stage of a step, a stage's parameters, a valid ``stop_at``."""

from __future__ import annotations

import numbers
from typing import Any

from dance_core.errors import DanceError, TrainingError
from dance_core.recipe.schema import StageSpec


def check_stop_at(stop_at: int | None, total: int, start: int = 0) -> None:
    """``stop_at`` must be a step after ``start`` and within the run's ``total`` steps."""
    if stop_at is None:
        return
    if isinstance(stop_at, bool) or not isinstance(stop_at, numbers.Integral):
        raise DanceError(f"stop_at: must be a whole number of steps, got {stop_at!r}")
    stop_at = int(stop_at)
    if stop_at <= 0:
        raise DanceError(f"stop_at: must be a positive step, got {stop_at}")
    if stop_at > total:
        raise DanceError(f"stop_at: step {stop_at} is beyond the run's last step ({total}, training.steps)")
    if stop_at <= start:
        raise DanceError(f"stop_at: step {stop_at} is not after the step the run resumes from ({start})")


def stage_at(stages: list[StageSpec], step: int) -> tuple[int, int]:
    """(stage index, step within the stage) of a global step."""
    start = 0
    for i, stage in enumerate(stages):
        if step < start + stage.steps:
            return i, step - start
        start += stage.steps
    return len(stages) - 1, stages[-1].steps


def trainable_parameters(model: Any, stage: StageSpec) -> list[Any]:
    """Parameters whose names start with one of the stage's prefixes (all when none given)."""
    named = list(model.named_parameters())
    if not stage.trainable:
        return [p for _, p in named]
    chosen = [p for n, p in named if any(n.startswith(prefix) for prefix in stage.trainable)]
    if not chosen:
        raise TrainingError(f"training.stages.{stage.name}.trainable: no parameter matches {stage.trainable}")
    return chosen
