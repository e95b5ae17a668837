"""What a training run reads: the recipe's data prepared (``data.prepare.prepare_data``, the step
held-out evaluation shares), split into training and validation clips, standardized with statistics
fitted on the training clips (or a warm start's), and the motion description its checkpoints record."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from dance_core.data.features import FeatureStack
from dance_core.data.motion_info import MotionInfo
from dance_core.data.prepare import PreparedData, cached_features, motion_info, prepare_data
from dance_core.data.sampling import split_clips
from dance_core.data.sources import Clip, ClipSource
from dance_core.data.stats import NormStats
from dance_core.errors import DanceError
from dance_core.progress import progress_bar
from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry
from dance_core.warm_start import init_stats


@dataclass
class TrainData:
    """A run's data: what was prepared, the standardized training and validation clips, their
    statistics and the motion description."""

    prepared: PreparedData
    train: list[Clip]
    val: list[Clip]
    stats: NormStats
    motion: MotionInfo


def training_data(
    recipe: Recipe,
    stack: FeatureStack,
    registry: Registry,
    *,
    init: Any = None,
    prepared: PreparedData | None = None,
    warm: Callable[[list[ClipSource]], None] | None = None,
    quiet: bool = False,
) -> TrainData:
    """Prepare the recipe's data (unless ``prepared`` is given: data prepared once for several runs),
    split it with the recipe's seed and standardize it; ``init``, a warm start's checkpoint, gives its
    statistics when ``training.init.stats``. ``warm`` sees the sources before their features are
    extracted (:func:`warm_feature_cache`)."""
    if prepared is None:
        with progress_bar(quiet) as bar:
            task = None

            def before(sources: list[ClipSource]) -> None:
                nonlocal task
                if warm is not None:
                    warm(sources)
                if bar:
                    task = bar.add_task("features", total=len(sources), info="")

            def advance(source: ClipSource) -> None:
                if bar:
                    bar.update(task, advance=1, info=source.name)

            prepared = prepare_data(recipe, stack, registry, before_features=before, progress=advance)
    train, val = split_clips(prepared.clips, recipe.data.val_fraction, recipe.seed)
    stats = NormStats.fit(train, stack.categorical())
    if init is not None and recipe.training.init.stats:
        stats = init_stats(init, stats)
    train = [stats.apply(c) for c in train]
    val = [stats.apply(c) for c in val]
    motion = motion_info(recipe, prepared.sources, train[0].motion.shape[1])
    return TrainData(prepared, train, val, stats, motion)


def warm_feature_cache(
    sources: list[ClipSource], stack: FeatureStack, registry: Registry, rank: int, world: int
) -> bool:
    """Several ranks: each extracts its share of the songs a dataset caches (``data.cache``) into the
    cache; when this returns True (some songs are cached) the caller waits for every rank (a barrier),
    then each reads every song from the cache. A song that fails here fails again, on every rank alike,
    when the clips are made."""
    cached = [s for s in sources if s.meta.get("feature_cache") and s.audio_path is not None]
    songs: dict[tuple[str, str], ClipSource] = {}
    for source in cached:  # a mirrored copy shares its song's features
        songs.setdefault((str(source.audio_path), repr(source.texts)), source)
    for source in list(songs.values())[rank::world]:
        with contextlib.suppress(DanceError, OSError, ValueError):
            cached_features(source, stack, registry, source.meta["feature_cache"])
    return bool(songs)
