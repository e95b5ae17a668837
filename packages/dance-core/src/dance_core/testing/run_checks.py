"""Contract checks of what a run is made of besides the model: datasets and schedules."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from dance_core import registry
from dance_core.contexts import DatasetContext
from dance_core.protocols import MotionData
from dance_core.testing.kit import create


def check_dataset(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    fps: float = 20.0,
    seed: int = 0,
    root: str = ".",
    registry: registry.Registry | None = None,
) -> list[Any]:
    """Build dataset ``name`` and check its clips: at least one, uniquely named ``ClipSource``s with finite
    ``(T, D)`` motion (one ``D`` for all), a positive fps, and music (audio or a file) or text; a second
    build with the same seed gives the same first clip. Returns the clips."""
    from dance_core.data.sources import ClipSource

    context = DatasetContext(fps, seed, root)
    dataset, check = create("dataset", name, options, context, registry)
    with check.calling("clips()"):
        clips = list(dataset.clips())
    check.that(clips, "clips() returned no clips")
    widths, names = set(), set()
    for clip in clips:
        check.that(isinstance(clip, ClipSource), f"clips() gave a {type(clip).__name__}, not a ClipSource")
        label = f"clip {clip.name!r}"
        check.that(clip.name not in names, f"two clips are named {clip.name!r}")
        names.add(clip.name)
        check.that(isinstance(clip.motion, MotionData), f"{label}: motion is not a MotionData")
        values = np.asarray(clip.motion.values)
        check.that(values.ndim == 2 and len(values) > 0, f"{label}: motion values have shape {values.shape}")
        check.that(bool(np.isfinite(values).all()), f"{label}: motion has NaN or inf values")
        check.that(clip.motion.fps > 0, f"{label}: fps is {clip.motion.fps}")
        check.that(
            clip.audio is not None or clip.audio_path is not None or clip.texts,
            f"{label}: has neither music (audio or audio_path) nor text",
        )
        widths.add(values.shape[1])
    check.that(len(widths) == 1, f"clips have different motion widths {sorted(widths)}")
    again, _ = create("dataset", name, options, context, registry)
    with check.calling("clips() of a second build"):
        first = next(iter(again.clips()))
    same = np.array_equal(np.asarray(first.motion.values), np.asarray(clips[0].motion.values))
    check.that(
        first.name == clips[0].name and same,
        "two builds with the same seed give different first clips (derive every random draw from the seed)",
    )
    return clips


def check_schedule(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    total_steps: int = 100,
    registry: registry.Registry | None = None,
) -> Any:
    """Build schedule ``name`` and check that it gives a finite number at the start, middle and end of
    training. Returns the schedule."""
    schedule, check = create("schedule", name, options, None, registry)
    for step in (0, total_steps // 2, total_steps - 1):
        with check.calling(f"the value at step {step}"):
            value = schedule(step, step // 10, total_steps)
        check.that(
            isinstance(value, int | float | np.number) and math.isfinite(value),
            f"the value at step {step} is {value!r}, not a finite number",
        )
    return schedule
