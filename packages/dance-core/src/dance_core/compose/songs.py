"""One song's inputs to a trained model: its features and text spans, the seed motion, the model itself."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from dance_core.checkpoint import Checkpoint, check_matches, load_checkpoint, load_weights
from dance_core.contexts import DEFAULT_FORMATS, FormatOptions
from dance_core.data.features import FeatureStack, load_audio
from dance_core.data.files import read_motion_file
from dance_core.errors import DataError
from dance_core.media import TextSpan, frame_count
from dance_core.model import ComposedModel, build_model
from dance_core.recipe.schema import Recipe, TextSpec
from dance_core.registry import Registry
from dance_core.spans import SpanTable


@dataclass
class Song:
    """One song's name, features and frame count, its text spans (as given, and as a table over its
    frames with the text streams' rows, standardized), and its beat times when the dance is aligned to them."""

    name: str
    streams: dict[str, np.ndarray]
    n_frames: int
    path: str = ""
    texts: tuple[TextSpan, ...] = ()
    spans: SpanTable | None = None
    beats: np.ndarray | None = None  # beat times (s), for compose.beat_align


def seed_motion(
    spec: str | None, ckpt: Checkpoint, frames: int, registry: Registry, formats: FormatOptions = DEFAULT_FORMATS
) -> np.ndarray:
    """Normalized seed ``(frames, D)``: the mean pose for ``rest``/None, else a motion file (read with its
    format's options in ``formats``)."""
    dim = ckpt.motion.dim
    if spec in (None, "rest"):
        return np.zeros((frames, dim), np.float32)
    motion = ckpt.motion.encode(read_motion_file(spec, registry, formats=formats), registry)
    if motion.values.shape[1] != dim:
        raise DataError(f"{spec}: seed motion has {motion.values.shape[1]} channels, the model {dim}")
    if abs(motion.fps - ckpt.motion.fps) > 1e-6:
        raise DataError(f"{spec}: seed motion is at {motion.fps:g} fps, the model at {ckpt.motion.fps:g}")
    values = ckpt.stats.motion.apply(motion.values)
    if len(values) < frames:
        values = np.concatenate([np.repeat(values[:1], frames - len(values), axis=0), values])
    return values[len(values) - frames :]


def song_texts(texts: list[TextSpec], duration: float, where: str) -> tuple[TextSpan, ...]:
    """The recipe's text spans on one song (an open end is the song's end); a span past the song is an error."""
    spans = []
    for i, t in enumerate(texts):
        start, end = t.start or 0.0, min(t.end or duration, duration)
        if start >= duration:
            raise DataError(
                f"{where}: compose.texts.{i}: starts at {start:g} s, after the song's end ({duration:.1f} s)"
            )
        spans.append(TextSpan(t.text, start, end))
    return tuple(spans)


def beat_tracker_of(recipe: Recipe, registry: Registry) -> str | None:
    """The tracker whose beats ``compose.beat_align`` aligns to: the recipe's beat feature's ``tracker``
    (the beats the model hears), else ``flux``; None when the recipe does not align."""
    if not recipe.compose.beat_align:
        return None
    for specs in recipe.features.values():
        for spec in specs:
            entry = registry.find("feature", spec.plugin)
            if entry.info.get("beats") and spec.options().get("tracker"):
                return str(spec.options()["tracker"])
    return "flux"


#: seconds of music decoded past ``--seconds``, so the features of the last frames see what follows
SEEK_MARGIN_S = 5.0


def load_song(
    path: str, stack: FeatureStack, ckpt: Checkpoint, seconds: float | None, registry: Registry,
    texts: list[TextSpec] = (), tracker: str | None = None,
) -> Song:
    """Features of one song (and its text spans' table), standardized with the checkpoint's statistics;
    with ``tracker``, its beats by that tracker too (:func:`beat_tracker_of`)."""
    # decode no more than asked (and a margin the features' windows look past the end with)
    audio = load_audio(path, registry, stack.formats, seconds + SEEK_MARGIN_S if seconds else None)
    n_audio = audio.n_frames(stack.fps)
    spans = song_texts(list(texts), n_audio / stack.fps, path)
    raw, table = stack.extract_spans(n_audio, audio, spans)
    n = frame_count(seconds, stack.fps) if seconds else n_audio
    streams = {}
    for name, values in raw.items():
        if name not in ckpt.stats.streams:
            raise DataError(f"{path}: feature stream {name!r} has no statistics in {ckpt.path}")
        values = ckpt.stats.streams[name].apply(values)
        if n > len(values):
            values = np.concatenate([values, np.repeat(values[-1:], n - len(values), axis=0)])
        streams[name] = values[:n]
    table = table.map_features(ckpt.stats.apply_rows)
    table = table.extend(n) if n > n_audio else table.crop(0, n)
    beats = None
    if tracker is not None:
        from dance_core.data.beat_tracking import TRACK_FPS, tracked_beats

        frames, _ = tracked_beats(audio, registry, tracker)
        beats = frames / TRACK_FPS
    return Song(Path(path).stem, streams, n, str(path), spans, table, beats)


def load_model(
    recipe: Recipe, checkpoint: str | Path, device: torch.device
) -> tuple[ComposedModel, Checkpoint, FeatureStack]:
    """Build the recipe's model and load a checkpoint that matches it."""
    ckpt = load_checkpoint(checkpoint)
    check_matches(ckpt, recipe)
    stack = FeatureStack(recipe)
    model = build_model(recipe, ckpt.motion.dim, stack.dims())
    load_weights(model, ckpt)
    return model.to(device).eval(), ckpt, stack
