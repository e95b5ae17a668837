"""Audio loading through registered readers, and the recipe's stacks of feature extractors (per-frame
streams, and the span table of the text streams)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dance_core.contexts import DEFAULT_FORMATS, FormatOptions
from dance_core.errors import DataError
from dance_core.media import Audio, FeatureInputs, TextSpan
from dance_core.protocols import SpanFeatureExtractor
from dance_core.recipe.schema import Recipe
from dance_core.registry import Registry
from dance_core.spans import SpanTable

MIN_SECONDS = 0.5


def audio_reader_for(path: Path, registry: Registry, formats: FormatOptions = DEFAULT_FORMATS):
    """The registered audio reader for a file suffix, built with its options in ``formats``."""
    suffix = path.suffix.lower()
    entry = registry.for_suffix("audio-reader", suffix)  # the highest ``priority=`` wins (core's: 0)
    if entry is not None:
        return formats.build(entry)
    known = sorted(registry.suffixes("audio-reader"))
    more = "" if len(registry.entries("audio-reader")) > 1 else "; install dance-audio for more formats"
    raise DataError(
        f"{path}: no audio reader for {suffix or 'files without a suffix'!r} (readable: {', '.join(known)}{more})"
    )


def check_audio_path(path: str | Path) -> Path:
    """The path, if it names a non-empty file; otherwise a one-line error (for every audio reader)."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: audio file not found")
    if path.is_dir():
        raise DataError(f"{path}: is a folder, not an audio file")
    if path.stat().st_size == 0:
        raise DataError(f"{path}: audio file is empty")
    return path


#: a sample's magnitude past which audio is refused: far outside [-1, 1] (40 dB over full scale), a
#: damaged or mis-scaled float file whose features would overflow
MAX_PEAK = 100.0


def read_audio(reader, path: str | Path, seconds: float | None = None) -> Audio:
    """``reader.read(path)``, decoding only the first ``seconds`` when given (readers that take a
    ``seconds=`` keyword decode no more, so memory is bounded by what is asked; others are cut after)."""
    import inspect

    try:
        takes = "seconds" in inspect.signature(reader.read).parameters
    except (TypeError, ValueError):
        takes = False
    audio = reader.read(str(path), seconds=seconds) if takes and seconds is not None else reader.read(str(path))
    if seconds is not None:
        keep = max(1, int(np.ceil(float(seconds) * max(int(audio.rate), 1))))
        if len(audio.samples) > keep:
            audio = Audio(audio.samples[:keep], audio.rate, audio.path)
    return audio


def check_audio(audio: Audio, path: str | Path) -> Audio:
    """A reader's output as every consumer may assume it: a positive rate, finite samples within
    ``MAX_PEAK``; else one line naming the file."""
    rate = int(audio.rate) if np.isfinite(audio.rate) else 0
    if rate < 1:
        raise DataError(f"{path}: audio header gives a sample rate of {audio.rate} Hz; the file is damaged")
    samples = np.asarray(audio.samples)
    if samples.size and not np.all(np.isfinite(samples)):
        raise DataError(f"{path}: audio holds NaN or infinite samples")
    peak = float(np.max(np.abs(samples))) if samples.size else 0.0
    if peak > MAX_PEAK:
        raise DataError(f"{path}: audio samples reach {peak:.3g}, far outside [-1, 1] (a damaged or mis-scaled "
                        "float file); normalize it first")
    return audio


def load_audio(path: str | Path, registry: Registry, formats: FormatOptions = DEFAULT_FORMATS,
               seconds: float | None = None) -> Audio:
    """Read a music file (its reader built with its options in ``formats``, a recipe's ``formats:``),
    only its first ``seconds`` when given; missing, empty, too-short, damaged (rate 0, non-finite or
    absurd samples) files are one-line errors."""
    path = check_audio_path(path)
    audio = check_audio(read_audio(audio_reader_for(path, registry, formats), path, seconds), path)
    if audio.duration < MIN_SECONDS:
        raise DataError(f"{path}: audio is {audio.duration:.2f} s long; at least {MIN_SECONDS} s needed")
    return audio


class FeatureStack:
    """The recipe's ``features:``: per stream, extractors whose outputs are concatenated."""

    def __init__(self, recipe: Recipe):
        self.fps = recipe.fps
        self.streams = {
            name: [(spec.plugin, spec.build()) for spec in specs]
            for name, specs in recipe.features.items()
        }
        #: the extractors and their options, per stream (what feature caches are keyed by)
        #: an extractor whose output changed for the same options declares ``revision`` (an int): it is
        #: part of the signature, so features cached before the change are computed again
        self.signature = {name: [{"plugin": s.plugin, **s.options(),
                                  **({"revision": x.revision} if getattr(x, "revision", None) is not None else {})}
                                 for s, (_, x) in zip(specs, self.streams[name], strict=True)]
                          for name, specs in recipe.features.items()}
        #: the recipe's ``formats:``: the audio readers' options when songs are read for these features
        self.formats: FormatOptions = recipe.format_options

    def reader_options(self) -> dict[str, dict]:
        """Audio readers given options by the recipe, by name (part of a feature cache's key when any)."""
        return {name: config.model_dump(mode="json") for (kind, name), config in sorted(self.formats.configs.items())
                if kind == "audio-reader" and config is not None}

    def categorical(self) -> dict[str, np.ndarray]:
        """Per stream, which channels hold ids (extractors with ``categorical = True``): never standardized."""
        return {
            name: np.concatenate([np.full(x.dim(), bool(getattr(x, "categorical", False))) for _, x in exts])
            if exts else np.zeros(0, bool)
            for name, exts in self.streams.items()
        }

    def dims(self) -> dict[str, int]:
        """Width of every stream."""
        return {name: sum(x.dim() for _, x in exts) for name, exts in self.streams.items()}

    def text_streams(self) -> list[str]:
        """Streams of text alone: every extractor gives one row per span (``SpanFeatureExtractor``), so
        the stream has rows in the span table."""
        return [name for name, exts in self.streams.items()
                if exts and all(isinstance(x, SpanFeatureExtractor) for _, x in exts)]

    def extract(
        self, n_frames: int, audio: Audio | None = None, texts: tuple[TextSpan, ...] = ()
    ) -> dict[str, np.ndarray]:
        """Every stream, ``(n_frames, dim)`` float32; non-finite output is an error naming the extractor."""
        return self.extract_spans(n_frames, audio, texts)[0]

    def extract_spans(
        self, n_frames: int, audio: Audio | None = None, texts: tuple[TextSpan, ...] = ()
    ) -> tuple[dict[str, np.ndarray], SpanTable]:
        """Every stream (as :meth:`extract`) and the texts' span table over the frames, with the rows of
        the text streams; a span extractor's rows are computed once and laid over the frames."""
        table = SpanTable.at(texts, n_frames, self.fps)
        inputs = FeatureInputs(n_frames=n_frames, audio=audio, texts=table.spans)
        text = set(self.text_streams())
        out, rows = {}, {}
        for name, extractors in self.streams.items():
            parts, span_parts = [], []
            for plugin, extractor in extractors:
                if isinstance(extractor, SpanFeatureExtractor):
                    span_parts.append(self._rows(plugin, extractor, table.spans, audio))
                    values = table.per_frame(span_parts[-1])
                else:
                    values = np.asarray(extractor.extract(inputs, self.fps), dtype=np.float32)
                if values.shape != (n_frames, extractor.dim()):
                    raise DataError(
                        f"feature {plugin!r} returned {values.shape}, expected {(n_frames, extractor.dim())}"
                    )
                if not np.all(np.isfinite(values)):
                    raise DataError(f"{_where(audio)}: feature {plugin!r} produced NaN or inf")
                parts.append(values)
            out[name] = np.concatenate(parts, axis=1) if parts else np.zeros((n_frames, 0), np.float32)
            if name in text:
                rows[name] = np.concatenate(span_parts, axis=1)
        return out, table.with_features(rows)

    def span_table(self, n_frames: int, texts: tuple[TextSpan, ...] = (), audio: Audio | None = None) -> SpanTable:
        """The texts' span table with the rows of the text streams alone (streams read from a cache)."""
        table = SpanTable.at(texts, n_frames, self.fps)
        return table.with_features({
            name: np.concatenate([self._rows(p, x, table.spans, audio) for p, x in self.streams[name]], axis=1)
            for name in self.text_streams()
        })

    @staticmethod
    def _rows(plugin: str, extractor: SpanFeatureExtractor, spans: tuple[TextSpan, ...],
              audio: Audio | None) -> np.ndarray:
        """An extractor's rows, one per span, checked: ``(S, dim)`` finite float32."""
        rows = np.asarray(extractor.span_features(spans), dtype=np.float32)
        if rows.shape != (len(spans), extractor.dim()):
            raise DataError(f"feature {plugin!r} returned {rows.shape} span rows, expected "
                            f"{(len(spans), extractor.dim())}")
        if not np.all(np.isfinite(rows)):
            raise DataError(f"{_where(audio)}: feature {plugin!r} produced NaN or inf for a text span")
        return rows


def _where(audio: Audio | None) -> str:
    return str(audio.path) if audio is not None and audio.path else "input"
