"""One song's inputs to a trained model: its features and text spans, the seed motion, the model itself."""

from __future__ import annotations

from dataclasses import dataclass, replace
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
    start: float = 0.0  # where the dance's first frame is in the song (s; compose.start)


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


def song_texts(texts: list[TextSpec], duration: float, where: str, first: float = 0.0) -> tuple[TextSpan, ...]:
    """The recipe's text spans on one song, in the song's time (an open end is the song's end); a span past
    the song's end, or ending before ``first`` (where the dance starts: ``compose.start``), is an error."""
    spans = []
    for i, t in enumerate(texts):
        start, end = t.start or 0.0, min(t.end or duration, duration)
        if start >= duration:
            raise DataError(
                f"{where}: compose.texts.{i}: starts at {start:g} s, after the song's end ({duration:.1f} s)"
            )
        if end <= first:
            raise DataError(f"{where}: compose.texts.{i}: ends at {end:g} s, before the dance starts "
                            f"(--start {first:g} s; text spans are in the song's time)")
        spans.append(TextSpan(t.text, start, end))
    return tuple(spans)


def shifted(spans: tuple[TextSpan, ...], by: float) -> tuple[TextSpan, ...]:
    """The spans ``by`` seconds earlier, cut at 0 (song time to a later origin's time)."""
    return tuple(TextSpan(s.text, max(s.start - by, 0.0), None if s.end is None else s.end - by) for s in spans)


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
    texts: list[TextSpec] = (), tracker: str | None = None, start: float = 0.0,
) -> Song:
    """Features of one song (and its text spans' table), standardized with the checkpoint's statistics;
    with ``tracker``, its beats by that tracker too (:func:`beat_tracker_of`). With ``start`` (seconds,
    ``compose.start``) the song is danced from there on: its features are those of the whole song's
    frames from ``start`` (the music up to ``SEEK_MARGIN_S`` before it decoded too, for the windows that
    look back), beats and the texts' table from the dance's first frame; ``texts`` are in the song's time."""
    fps = stack.fps
    first = int(round(start * fps))  # the dance's first frame, in the song's frames
    # decode no more than asked (and a margin the features' windows look past the end with)
    audio = load_audio(path, registry, stack.formats, start + seconds + SEEK_MARGIN_S if seconds else None)
    if first and first >= audio.n_frames(fps):
        raise DataError(f"{path}: --start (compose.start) {start:g} s is at or after the song's end "
                        f"({audio.duration:.1f} s)")
    spans = song_texts(list(texts), audio.n_frames(fps) / fps, path, first / fps)
    lead = min(first, int(round(SEEK_MARGIN_S * fps)))  # frames of music before the dance its features see
    cut = first - lead
    if cut:  # the song from ``lead`` frames before the dance (a whole number of frames, as the features' grid)
        audio = replace(audio, samples=audio.samples[int(round(cut * audio.rate / fps)):])
    n_audio = audio.n_frames(fps)
    raw, table = stack.extract_spans(n_audio, audio, shifted(spans, cut / fps))
    n = frame_count(seconds, fps) if seconds else n_audio - lead
    streams = {}
    for name, values in raw.items():
        if name not in ckpt.stats.streams:
            raise DataError(f"{path}: feature stream {name!r} has no statistics in {ckpt.path}")
        values = ckpt.stats.streams[name].apply(values)[lead:]
        if n > len(values):
            values = np.concatenate([values, np.repeat(values[-1:], n - len(values), axis=0)])
        streams[name] = values[:n]
    table = table.map_features(ckpt.stats.apply_rows)
    table = table.extend(lead + n) if lead + n > n_audio else table.crop(0, lead + n)
    if lead:  # the dance's frames, its spans in the dance's time
        table = table.crop(lead, lead + n)
        table = replace(table, spans=shifted(table.spans, lead / fps))
    beats = None
    if tracker is not None:
        from dance_core.data.beat_tracking import TRACK_FPS, tracked_beats

        frames, _ = tracked_beats(audio, registry, tracker)
        beats = frames / TRACK_FPS - lead / fps
        beats = beats[beats >= 0] if lead else beats
    texts_here = shifted(spans, first / fps) if first else spans
    return Song(Path(path).stem, streams, n, str(path), texts_here, table, beats, first / fps)


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
