"""A recipe's feature streams computed as audio arrives, frame by frame, with a fixed look-ahead.

Frame ``i`` describes time ``i / fps`` (the offline alignment rule). An extractor with a
``streaming(fps, rate)`` method (dance-audio's ``beats``: the tracker's forward pass) gives its own
causal stream: ``push(samples)`` returns the frames it completes, ``finish(n_frames)`` the rest.
Every other extractor is run with its offline code on a **rolling buffer** (:class:`RollingExtractor`):
the last second or two of audio, starting on a whole second so the frame grid is the song's, and a
frame is taken once the audio reaches its time plus the extractor's ``lookahead`` (seconds, an
attribute the extractor may declare; :data:`DEFAULT_LOOKAHEAD` otherwise). Extractors whose frames
read only a window around their time (log-mel, onset flux, energy) then give the offline values;
one that normalises over the whole song (``mel`` with ``reference: max``) cannot, and says so.
A text stream (``word-tokens``) gives, per frame, the row of the span in force among those given so far
(:class:`dance_core.live.texts.LiveTexts`; zeros where none is, as offline).
"""

from __future__ import annotations

import math

import numpy as np

from dance_core.checkpoint import Checkpoint
from dance_core.data.features import FeatureStack
from dance_core.errors import DataError
from dance_core.media import Audio, FeatureInputs
from dance_core.protocols import SpanFeatureExtractor

#: seconds of audio past a frame's time a rolling extractor waits for, when it declares no ``lookahead``
DEFAULT_LOOKAHEAD = 0.1
#: seconds of audio kept before the first frame still to compute (context for windows and differences)
CONTEXT = 1.0


class RollingExtractor:
    """An offline extractor run over the last seconds of audio: the frames whose window is complete."""

    def __init__(self, name: str, extractor, fps: float, rate: int):
        options = getattr(extractor, "reference", None)
        if options == "max":
            raise DataError(f"feature {name!r}: reference 'max' normalises over the whole song; it cannot run live "
                            "(use reference 'one')")
        self.name, self.extractor, self.fps, self.rate = name, extractor, float(fps), int(rate)
        self.lookahead = float(getattr(extractor, "lookahead", DEFAULT_LOOKAHEAD))
        self.buffer = np.zeros(0, np.float32)
        self.start = 0  # whole seconds: the buffer's first sample is start * rate
        self.frames = 0  # frames given so far

    def dim(self) -> int:
        """The extractor's width."""
        return self.extractor.dim()

    def push(self, samples: np.ndarray) -> np.ndarray:
        """Frames completed by the next block of samples ``(k, dim)``."""
        self.buffer = np.concatenate([self.buffer, np.asarray(samples, np.float32)])
        have = self.start + len(self.buffer) / self.rate  # seconds received
        last = math.floor((have - self.lookahead) * self.fps + 1e-9)
        return self._compute(last + 1, final=False)

    def finish(self, n_frames: int) -> np.ndarray:
        """The remaining frames up to ``n_frames`` (the audio ends here, as the song's file would)."""
        return self._compute(n_frames, final=True)

    def _compute(self, stop: int, final: bool) -> np.ndarray:
        if stop <= self.frames:
            return np.zeros((0, self.dim()), np.float32)
        first = int(round(self.start * self.fps))  # the buffer's frame 0
        audio = Audio(self.buffer, self.rate)
        values = np.asarray(self.extractor.extract(FeatureInputs(n_frames=stop - first, audio=audio), self.fps),
                            dtype=np.float32)
        out = values[self.frames - first :]
        self.frames = stop
        if not final:  # keep CONTEXT seconds before the next frame, from a whole second
            keep_from = max(self.start, math.floor(self.frames / self.fps - CONTEXT))
            self.buffer = self.buffer[(keep_from - self.start) * self.rate :]
            self.start = keep_from
        return out


class LiveFeatures:
    """The recipe's feature streams, standardised with the checkpoint's statistics, as audio arrives:
    ``push(samples)`` returns the new frames ``{stream: (k, dim)}`` (the same ``k`` for every stream),
    ``finish()`` the frames up to the end of the audio heard. ``lookahead`` is the largest declared
    look-ahead in seconds (a resampler's delay comes on top where rates differ).

    ``beats``: the names of beat-tracking extractors (registered ``beats=True``); the raw rows of the first
    one among the streams (before standardisation: beat, downbeat, sin and cos of the beat phase...) are
    kept for :meth:`take_beats`; when none of them tracks beats, a streaming tracker set as ``tracker`` is
    run beside the streams for those rows."""

    def __init__(self, stack: FeatureStack, checkpoint: Checkpoint, rate: int, beats: frozenset[str] = frozenset()):
        self.fps, self.rate = stack.fps, int(rate)
        self.stats = checkpoint.stats
        self.parts: dict[str, list] = {}
        self.beat_part: tuple[str, int] | None = None  # (stream, index) of the beat tracker among the parts
        self.beat_rows: list[np.ndarray] = []
        self.text_streams = stack.text_streams()
        self.texts = None  # the session's LiveTexts: the text streams' values (zeros without it)
        self.text_dims = {s: sum(x.dim() for _, x in stack.streams[s]) for s in self.text_streams}
        for stream, extractors in stack.streams.items():
            if stream not in checkpoint.stats.streams:
                raise DataError(f"live: feature stream {stream!r} has no statistics in {checkpoint.path}")
            if stream in self.text_streams:
                continue
            parts = []
            for plugin, extractor in extractors:
                if plugin in beats and self.beat_part is None:
                    self.beat_part = (stream, len(parts))
                if isinstance(extractor, SpanFeatureExtractor):
                    raise DataError(f"live: feature {plugin!r} reads text in stream {stream!r} beside audio "
                                    "features; live, a text stream holds text extractors alone")
                live = getattr(extractor, "streaming", None)
                parts.append(live(self.fps, self.rate) if live else RollingExtractor(plugin, extractor, self.fps,
                                                                                      self.rate))
            self.parts[stream] = parts
        self.tracker = None  # a streaming beat tracker fed beside the streams (set by the caller)
        self.lookahead = max((getattr(p, "lookahead", 0.0) for ps in self.parts.values() for p in ps), default=0.0)
        self.pending = {s: [np.zeros((0, p.dim()), np.float32) for p in ps] for s, ps in self.parts.items()}
        self.samples = 0
        self.frames = 0  # frames given so far

    def push(self, samples: np.ndarray) -> dict[str, np.ndarray]:
        """The frames completed by the next block of mono float samples."""
        samples = np.asarray(samples, np.float32)
        self.samples += len(samples)
        for stream, parts in self.parts.items():
            for k, part in enumerate(parts):
                self.pending[stream][k] = np.concatenate([self.pending[stream][k], part.push(samples)])
        if self.tracker is not None:
            self.beat_rows.append(self.tracker.push(samples))
        return self._ready()

    def finish(self) -> dict[str, np.ndarray]:
        """The frames left up to ``ceil(seconds heard * fps)``, the offline frame count."""
        n = math.ceil(self.samples / self.rate * self.fps - 1e-9)
        for stream, parts in self.parts.items():
            for k, part in enumerate(parts):
                self.pending[stream][k] = np.concatenate([self.pending[stream][k], part.finish(n)])
        if self.tracker is not None:
            self.beat_rows.append(self.tracker.finish(n))
        return self._ready()

    def take_beats(self) -> np.ndarray:
        """The beat tracker's raw rows made since the last call ``(k, columns)`` (none without a tracker)."""
        rows = [r for r in self.beat_rows if len(r)]
        self.beat_rows = []
        return np.concatenate(rows) if rows else np.zeros((0, 4), np.float32)

    def take_settled(self) -> list[tuple[float | None, np.ndarray]]:
        """The beat tracker's beats placed with hindsight since the last call, in order: ``(seconds of music
        they were placed with, beats in seconds)``, from a tracker that offers them (``take_settled()``, as
        dance-audio's streaming ``beats`` has; one with only ``settled_beats()`` gives its latest, heard
        ``None``: when is not known); empty otherwise."""
        part = self.parts[self.beat_part[0]][self.beat_part[1]] if self.beat_part is not None else self.tracker
        take = getattr(part, "take_settled", None)
        if take is not None:
            return [(float(heard), np.array(times, np.float64)) for heard, times in take()]
        settled = getattr(part, "settled_beats", None)
        return [(None, np.array(settled(), np.float64))] if settled is not None else []

    def _ready(self) -> dict[str, np.ndarray]:
        k = min(len(x) for xs in self.pending.values() for x in xs)
        out = {}
        for stream in self.text_streams:  # the spans given so far, laid over the new frames as offline
            values = self.texts.per_frame(stream, self.frames, self.frames + k) if self.texts is not None else \
                np.zeros((k, self.text_dims[stream]), np.float32)
            out[stream] = self.stats.streams[stream].apply(values).astype(np.float32)
        if self.beat_part is not None and k:
            self.beat_rows.append(self.pending[self.beat_part[0]][self.beat_part[1]][:k])
        for stream, parts in self.pending.items():
            values = np.concatenate([x[:k] for x in parts], axis=1)
            if not np.all(np.isfinite(values)):
                raise DataError(f"live: feature stream {stream!r} produced NaN or inf at frame {self.frames}")
            out[stream] = self.stats.streams[stream].apply(values).astype(np.float32)
            self.pending[stream] = [x[k:] for x in parts]
        self.frames += k
        return out
