"""Contract checks of what feeds and scores a model: feature extractors and metrics, with the inputs they need
(a short synthesized song, dancers on the default skeleton)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from dance_core import registry
from dance_core.media import Audio, FeatureInputs, TextSpan
from dance_core.protocols import JointClip, MetricResult, SpanFeatureExtractor
from dance_core.spans import SpanTable
from dance_core.testing.kit import create


def synthetic_audio(seconds: float = 3.0, rate: int = 22050, bpm: float = 120.0, seed: int = 0) -> Audio:
    """A short test song: a bass note and a chord, a click on every beat (louder on downbeats), noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * rate))) / rate
    audio = 0.1 * np.sin(2 * np.pi * 55.0 * t)
    for freq in (220.0, 277.2, 329.6):
        audio += 0.05 * np.sin(2 * np.pi * freq * t)
    period = 60.0 / bpm
    since = t % period
    beat = np.floor(t / period).astype(int)
    click = np.sin(2 * np.pi * np.where(beat % 4 == 0, 1500.0, 1000.0) * t) * np.exp(-since / 0.02)
    audio += np.where(beat % 4 == 0, 0.5, 0.3) * click
    audio += 0.005 * rng.standard_normal(len(t))
    return Audio(np.clip(audio, -1.0, 1.0).astype(np.float32), rate)


_TEXTS = (TextSpan("step to the left", 0.0, 1.0), TextSpan("turn around and clap", 1.0, None))


def check_feature(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    fps: float = 30.0,
    audio: Audio | None = None,
    texts: Sequence[TextSpan] | None = None,
    registry: registry.Registry | None = None,
) -> Any:
    """Build feature extractor ``name`` and check ``extract`` on a short song (default
    :func:`synthetic_audio`) with timed text (as in training) and without (as when composing), for the
    song's frame count at ``fps`` and for fewer frames (training crops music to the motion): each call
    gives ``(n_frames, dim())`` finite float32 values. A text extractor that gives one row per span
    (``span_features``, a ``SpanFeatureExtractor``) must give ``(len(texts), dim())`` finite float32
    rows, which laid over the frames are its ``extract`` values. Returns the extractor."""
    extractor, check = create("feature", name, options, None, registry)
    with check.calling("dim()"):
        dim = extractor.dim()
    check.count(dim, "dim()", 1)
    audio = audio or synthetic_audio()
    texts = tuple(_TEXTS if texts is None else texts)
    n = audio.n_frames(fps)
    for n_frames, spans in ((n, texts), (max(1, n - 3), ())):
        what = f"extract for {n_frames} frames at {fps:g} fps {'with' if spans else 'without'} text"
        with check.calling(what):
            values = extractor.extract(FeatureInputs(n_frames, audio, spans), fps)
        check.that(isinstance(values, np.ndarray), f"{what} returned a {type(values).__name__}, not a numpy array")
        check.that(values.shape == (n_frames, dim), f"{what} returned shape {values.shape}, expected {(n_frames, dim)}")
        check.that(values.dtype == np.float32, f"{what} returned {values.dtype}, expected float32")
        check.that(bool(np.isfinite(values).all()), f"{what} returned NaN or inf values")
        if isinstance(extractor, SpanFeatureExtractor):
            _check_span_rows(extractor, check, spans, n_frames, fps, values, dim)
    return extractor


def _check_span_rows(extractor: Any, check: Any, spans: tuple[TextSpan, ...], n_frames: int, fps: float,
                     values: np.ndarray, dim: int) -> None:
    """A span extractor's rows: one per span, finite float32, laid over the frames as ``extract`` gives them."""
    what = f"span_features of {len(spans)} spans"
    with check.calling(what):
        rows = extractor.span_features(spans)
    check.that(isinstance(rows, np.ndarray), f"{what} returned a {type(rows).__name__}, not a numpy array")
    check.that(rows.shape == (len(spans), dim), f"{what} returned shape {rows.shape}, expected {(len(spans), dim)}")
    check.that(rows.dtype == np.float32, f"{what} returned {rows.dtype}, expected float32")
    check.that(bool(np.isfinite(rows).all()), f"{what} returned NaN or inf values")
    laid = SpanTable.at(spans, n_frames, fps).per_frame(rows)
    check.that(np.array_equal(laid, values), f"{what}, laid over the frames, differ from extract's values")


def dancing_clips(n: int = 3, seconds: float = 4.0, fps: float = 30.0, seed: int = 0) -> list[JointClip]:
    """``n`` dancers on the default skeleton (SMPL-24 joints; metres, Y up, feet on the floor) bouncing on
    120 BPM beats with swinging limbs and a drifting root, with the music's beat times: input for metric
    checks."""
    from dance_core.motion.skeletons import SMPL_NAMES, dance24

    rest = dance24().rest_positions()
    t = np.arange(int(round(seconds * fps))) / fps
    beats = np.arange(0.25, seconds, 0.5)
    clips = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        phase = rng.uniform(0, 2 * np.pi, (24, 3))
        swing = rng.normal(0.0, 0.06, size=(1, 24, 3)) * np.sin(2 * np.pi * t[:, None, None] + phase)
        bounce = 0.04 * (1 - np.cos(2 * np.pi * (t - 0.25) / 0.5))[:, None, None] * [0.0, 1.0, 0.0]
        drift = 0.3 * np.sin(2 * np.pi * 0.1 * t + k)[:, None, None] * [1.0, 0.0, 0.0]
        positions = rest[None] + swing * (rest[None, :, 1:2] > 0.3) + bounce + drift
        clips.append(JointClip(f"dance{k}", positions.astype(np.float64), fps, list(SMPL_NAMES), beats.copy()))
    return clips


def check_metric(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    generated: Sequence[JointClip] | None = None,
    reference: Sequence[JointClip] | None = None,
    registry: registry.Registry | None = None,
) -> MetricResult:
    """Build metric ``name``, check ``needs``, score ``generated`` (default :func:`dancing_clips`) against
    ``reference`` (when given, or by default when the metric needs one), and check the result: a
    ``MetricResult`` of finite floats."""
    metric, check = create("metric", name, options, None, registry)
    needs = metric.needs
    check.that(
        isinstance(needs, tuple) and set(needs) <= {"reference", "music"},
        f"needs must be a tuple of 'reference' and/or 'music', got {needs!r}",
    )
    generated = list(generated or dancing_clips(3, seed=0))
    if reference is None and "reference" in needs:
        reference = dancing_clips(3, seed=1)
    with check.calling("scoring"):
        result = metric(generated, list(reference)) if reference is not None else metric(generated)
    check.that(isinstance(result, MetricResult), f"returned a {type(result).__name__}, not a MetricResult")
    check.that(result.values, "returned no values")
    for key, value in result.values.items():
        check.that(isinstance(key, str), f"value name {key!r} is not a string")
        check.that(isinstance(value, int | float) and math.isfinite(value), f"value {key!r} is {value!r}")
    for clip, values in result.per_clip.items():
        for key, value in values.items():
            check.that(isinstance(value, int | float), f"per_clip[{clip!r}][{key!r}] is {value!r}, not a number")
    return result
