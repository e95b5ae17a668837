"""Turn a recipe's dataset into standardized, aligned clips."""

from __future__ import annotations

from dance_core.data.features import FeatureStack, load_audio
from dance_core.data.sources import Clip, ClipSource
from dance_core.errors import DataError, RecipeError
from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry


def dataset_sources(recipe: Recipe) -> list[ClipSource]:
    """The recipe's dataset, built and listed."""
    if recipe.data is None:
        raise RecipeError(f"{recipe._origin}: data: required for training")
    dataset = recipe.data.dataset.build(fps=recipe.fps, seed=recipe.seed, root=recipe._dir)
    sources = list(dataset.clips())
    if not sources:
        raise DataError(f"dataset {recipe.data.dataset.plugin!r} has no clips")
    return sources


def to_clip(source: ClipSource, stack: FeatureStack, registry: Registry) -> Clip:
    """Features for one source, cropped with its motion to a common frame count."""
    motion = source.motion
    if abs(motion.fps - stack.fps) > 1e-6:
        raise DataError(f"{source.name}: motion is at {motion.fps:g} fps but the recipe's fps is {stack.fps:g}")
    audio = source.audio
    if audio is None and source.audio_path is not None:
        audio = load_audio(source.audio_path, registry)
    n = len(motion.values) if audio is None else min(len(motion.values), audio.n_frames(stack.fps))
    streams = stack.extract(n, audio, source.texts)
    return Clip(source.name, motion.values[:n], streams)
