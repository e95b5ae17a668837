"""Turn a recipe's dataset into standardized, aligned clips."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from dance_core.contexts import DatasetContext
from dance_core.data.features import FeatureStack, load_audio
from dance_core.data.motion_info import MotionInfo
from dance_core.data.sources import Clip, ClipSource
from dance_core.errors import DataError, RecipeError
from dance_core.protocols import MotionData
from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry


def dataset_sources(recipe: Recipe) -> list[ClipSource]:
    """The recipe's dataset, built and listed; skeletal motion is resampled to the recipe's fps and
    encoded with the recipe's ``motion:`` representation (mirrored copies added with ``data.mirror``)."""
    if recipe.data is None:
        raise RecipeError(f"{recipe.origin}: data: required for training")
    context = DatasetContext(fps=recipe.fps, seed=recipe.seed, root=recipe.folder, formats=recipe.format_options)
    dataset = recipe.data.dataset.build(context)
    sources = list(dataset.clips())
    if not sources:
        raise DataError(f"dataset {recipe.data.dataset.plugin!r} has no clips")
    return encode_sources(recipe, sources)


def encode_sources(recipe: Recipe, sources: list[ClipSource]) -> list[ClipSource]:
    """Sources whose ``motion.values`` are the representation's features at the recipe's fps."""
    skeletal = [s for s in sources if s.motion.skeleton_motion is not None]
    plugin = recipe.data.dataset.plugin if recipe.data else "?"
    if recipe.motion is None:
        if skeletal:
            raise RecipeError(f"{recipe.origin}: motion: dataset {plugin!r} yields skeletal motion; choose a "
                              "representation, e.g. `motion: {plugin: rotations}`")
        return sources
    if len(skeletal) != len(sources):
        bad = next(s for s in sources if s.motion.skeleton_motion is None)
        raise DataError(f"{bad.name}: motion has no skeleton, but the recipe's motion representation "
                        f"{recipe.motion.plugin!r} needs one")
    rep = recipe.motion.build()
    ref = sources[0].motion.skeleton_motion.skeleton
    out = []
    for s in sources:
        check_source_motion(s)
        motion = s.motion.skeleton_motion.conformed(ref, s.name)
        versions = [(s.name, motion.resample(recipe.fps))]
        if recipe.data is not None and recipe.data.mirror:
            versions.append((f"{s.name}-mirrored", versions[0][1].mirrored()))
        for name, m in versions:
            data = MotionData(rep.encode(m), recipe.fps, rep.channels(ref), dict(s.motion.meta), m)
            out.append(replace(s, name=name, motion=data, meta={**s.meta, "song": s.name}))
    return out


@dataclass
class PreparedData:
    """A recipe's data ready for a model, not yet standardized: the sources (motion encoded with the
    recipe's representation at its fps) and their clips (features extracted, cropped with the motion)."""

    sources: list[ClipSource]
    clips: list[Clip]

    def standardized(self, stats: Any) -> list[Clip]:
        """The clips standardized with ``stats`` (a ``NormStats``: the run's own, or a checkpoint's)."""
        return [stats.apply(c) for c in self.clips]


def prepare_data(
    recipe: Recipe,
    stack: FeatureStack,
    registry: Registry,
    sources: Iterable[ClipSource] | None = None,
    *,
    before_features: Callable[[list[ClipSource]], None] | None = None,
    progress: Callable[[ClipSource], None] | None = None,
) -> PreparedData:
    """The one data-preparation step of training and of held-out evaluation: the recipe's dataset (or
    ``sources``, clips as a dataset yields them) encoded with the recipe's motion representation
    (:func:`dataset_sources`, :func:`encode_sources`), then each source's features extracted and cropped
    with its motion (:func:`to_clip`). ``before_features`` sees the encoded sources first (a distributed
    run warms its feature cache there); ``progress`` is called with each source once its clip is made."""
    encoded = dataset_sources(recipe) if sources is None else encode_sources(recipe, list(sources))
    if before_features is not None:
        before_features(encoded)
    clips = []
    for source in encoded:
        clips.append(to_clip(source, stack, registry))
        if progress is not None:
            progress(source)
    return PreparedData(encoded, clips)


def motion_info(recipe: Recipe, sources: list[ClipSource], dim: int) -> MotionInfo:
    """What a checkpoint stores about its motion: width, fps, channels, representation and skeleton."""
    channels = sources[0].motion.channels
    info = MotionInfo(dim, recipe.fps, tuple(channels) if channels else None)
    if recipe.motion is None:
        return info
    config = recipe.motion.config  # validated, defaults filled in: decoding never depends on today's defaults
    options = config.model_dump(mode="json") if config is not None else recipe.motion.options()
    return replace(info, representation=recipe.motion.plugin, options=options,
                   skeleton=sources[0].motion.skeleton_motion.skeleton)


def motion_file(source: ClipSource) -> str:
    """The file a source's motion was read from; else the clip's name (and its music file)."""
    path = source.motion.meta.get("path")
    if path:
        return str(path)
    return f"clip {source.name!r}" + (f" (music {source.audio_path})" if source.audio_path else "")


def check_finite(values: np.ndarray, where: str, what: str) -> None:
    """One line naming ``where`` (a file) and ``what`` (motion, a feature stream) when ``values``
    hold NaN or infinite numbers, with the first frame at fault."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "fc" or arr.size == 0:
        return
    finite = np.isfinite(arr)
    if finite.all():
        return
    bad = ~finite
    frame = int(np.argwhere(bad)[0][0]) if arr.ndim else 0
    kinds = " and ".join(k for k, hit in (("NaN", np.isnan(arr).any()), ("infinite", np.isinf(arr).any())) if hit)
    raise DataError(f"{where}: {what} holds {kinds} values ({int(bad.sum())} of {arr.size}, first at frame "
                    f"{frame}); fix or remove this file before training")


def check_source_motion(source: ClipSource) -> None:
    """A dataset source's motion (frame array and skeletal motion) must be finite."""
    where = motion_file(source)
    check_finite(source.motion.values, where, "motion")
    skeletal = source.motion.skeleton_motion
    if skeletal is not None:
        for field in ("root", "rotations", "joint_positions"):
            value = getattr(skeletal, field, None)
            if value is not None:
                check_finite(value, where, f"motion ({field.replace('_', ' ')})")


def check_streams(source: ClipSource, streams: dict[str, np.ndarray]) -> None:
    """Every feature stream of a source must be finite; an error names the music file and the stream."""
    where = source.audio_path or source.name
    for name, values in streams.items():
        check_finite(values, str(where), f"feature stream {name!r}")


def to_clip(source: ClipSource, stack: FeatureStack, registry: Registry) -> Clip:
    """Features for one source, cropped with its motion to a common frame count, and its texts' span
    table over those frames (the text streams' rows computed anew when the streams come from the
    feature cache); motion at another frame rate is low-pass filtered and resampled to the recipe's.
    NaN or infinite motion or features stop here, with one line naming the file and the stream."""
    motion = source.motion
    values = motion.values
    check_finite(values, motion_file(source), "motion")
    if abs(motion.fps - stack.fps) > 1e-6:
        from dance_core.motion.resample import resample_array

        values = resample_array(np.asarray(values, np.float64), motion.fps, stack.fps).astype(np.float32)
    cache_dir = source.meta.get("feature_cache")
    if cache_dir and source.audio_path is not None:
        streams = cached_features(source, stack, registry, cache_dir)
        check_streams(source, streams)
        if streams:
            check_durations(source, len(values), len(next(iter(streams.values()))), stack.fps)
        n = min(len(values), *(len(v) for v in streams.values())) if streams else len(values)
        spans = stack.span_table(n, source.texts)
        return Clip(source.name, values[:n], {k: v[:n] for k, v in streams.items()}, source.meta.get("song", ""), spans)
    audio = source.audio
    if audio is None and source.audio_path is not None:
        audio = load_audio(source.audio_path, registry, stack.formats)
    if audio is not None:
        check_durations(source, len(values), audio.n_frames(stack.fps), stack.fps)
    n = len(values) if audio is None else min(len(values), audio.n_frames(stack.fps))
    streams, spans = stack.extract_spans(n, audio, source.texts)
    check_streams(source, streams)
    return Clip(source.name, values[:n], streams, source.meta.get("song", ""), spans)


def check_durations(source: ClipSource, motion_frames: int, audio_frames: int, fps: float) -> None:
    """A dataset's ``meta["max_offset"]`` (seconds) bounds how much motion and music lengths may differ."""
    limit = source.meta.get("max_offset")
    if limit is not None and abs(motion_frames - audio_frames) / fps > limit:
        raise DataError(f"{source.audio_path or source.name}: music lasts {audio_frames / fps:.2f} s but its "
                        f"motion {motion_frames / fps:.2f} s (more than {limit:g} s apart)")


def cached_features(source: ClipSource, stack: FeatureStack, registry: Registry, folder: str) -> dict[str, Any]:
    """Full-length feature streams of a source's audio file, from (or into) the feature cache."""
    from dance_core.data.cache import FeatureCache

    cache = FeatureCache(folder)
    texts = [[t.text, t.start, t.end] for t in source.texts]
    settings = {"features": stack.signature, "fps": stack.fps, "texts": texts}
    readers = stack.reader_options()
    if readers:  # only then: the keys of caches written without reader options stay as they were
        settings["readers"] = readers
    key = cache.key(source.audio_path, settings)
    streams = cache.get(key)
    if streams is None:
        audio = load_audio(source.audio_path, registry, stack.formats)
        streams = stack.extract(audio.n_frames(stack.fps), audio, source.texts)
        cache.put(key, streams)
    return streams
