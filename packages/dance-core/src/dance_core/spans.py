"""Text spans as tables: a song's spans at the recipe's frame rate, and a batch's spans for a model.

A ``--text`` span or a dataset's timed text (a ``TextSpan``, seconds) covers the frames ``i`` with
``start <= i / fps < end``. Where spans overlap, the one that started last is in force (the newest
instruction). A table keeps every span as its own row, so two adjacent spans with the same sentence
stay two spans; a model reads the span in force at each frame from the table's ``index``.

- :class:`SpanTable`: one song or clip (NumPy), what data preparation and composition make.
- :class:`TextSpans`: a batch (torch tensors), what heads read in ``TrainContext.spans`` and
  ``SongInputs.spans``.

Each holds, per text stream (a stream whose extractors all give one row of features per span), one
row of that stream's features per span, standardized as the stream is (ids unchanged).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dance_core.media import TextSpan


def span_index(texts: Sequence[TextSpan], n_frames: int, fps: float) -> np.ndarray:
    """``(n_frames,)`` index into ``texts`` of the span in force at each frame, -1 where none is
    (where spans overlap, the one that started last)."""
    t = np.arange(n_frames) / fps
    owner = np.full(n_frames, -1, dtype=np.int64)
    started = np.full(n_frames, -np.inf)
    for k, span in enumerate(texts):
        end = np.inf if span.end is None else span.end
        cover = (t >= span.start) & (t < end) & (span.start >= started)
        owner[cover] = k
        started[cover] = span.start
    return owner


def span_frames(texts: Sequence[TextSpan], n_frames: int, fps: float) -> np.ndarray:
    """``(S, 2)`` ``[start, end)`` frames each span covers (``start <= i / fps < end``), within the frames."""
    t = np.arange(n_frames) / fps
    out = np.zeros((len(texts), 2), dtype=np.int64)
    for k, span in enumerate(texts):
        first = int(np.searchsorted(t, span.start, side="left"))
        last = n_frames if span.end is None else int(np.searchsorted(t, span.end, side="left"))
        out[k] = first, max(first, last)
    return out


def _kept(frames: np.ndarray, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
    """Frame ranges shifted to ``start`` and clipped to ``[0, stop - start)``, and which still hold a frame."""
    clipped = np.clip(frames - start, 0, max(stop - start, 0))
    return clipped, clipped[:, 1] > clipped[:, 0]


@dataclass(frozen=True)
class SpanTable:
    """One song's or clip's text spans at the recipe's frame rate.

    ``spans``: the ``S`` spans; ``frames (S, 2)``: the ``[start, end)`` frames each covers;
    ``index (T,)``: per frame the span in force (into ``spans``; -1 where none); ``features``: per text
    stream, ``(S, C)`` float32, one row of the stream's features per span."""

    spans: tuple[TextSpan, ...]
    frames: np.ndarray
    index: np.ndarray
    features: Mapping[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def at(cls, texts: Sequence[TextSpan], n_frames: int, fps: float,
           features: Mapping[str, np.ndarray] | None = None) -> SpanTable:
        """The table of ``texts`` over ``n_frames`` frames at ``fps`` (one row per text, in order)."""
        texts = tuple(texts)
        return cls(texts, span_frames(texts, n_frames, fps), span_index(texts, n_frames, fps), dict(features or {}))

    @property
    def n_frames(self) -> int:
        """Frames the table covers."""
        return len(self.index)

    def per_frame(self, rows: np.ndarray) -> np.ndarray:
        """``rows (S, C)``, one per span, laid over the frames: ``(T, C)`` float32, each frame the row of
        the span in force, zeros where none is (a text stream as windowed models read it)."""
        rows = np.asarray(rows)
        table = np.zeros((len(self.spans) + 1, rows.shape[1] if rows.ndim == 2 else 0), dtype=np.float32)
        table[: len(self.spans)] = rows  # the last row: no span
        return table[self.index]

    def with_features(self, features: Mapping[str, np.ndarray]) -> SpanTable:
        """The same spans with these rows of features per text stream."""
        return replace(self, features=dict(features))

    def map_features(self, fn: Callable[[str, np.ndarray], np.ndarray]) -> SpanTable:
        """The same spans with ``fn(stream, rows)`` as each stream's rows (standardization)."""
        return self.with_features({name: fn(name, rows) for name, rows in self.features.items()})

    def crop(self, start: int, stop: int) -> SpanTable:
        """Frames ``[start, stop)``, with the spans that cover at least one of them (renumbered in order)."""
        frames, keep = _kept(self.frames, start, stop)
        new = np.cumsum(keep) - 1
        index = self.index[start:stop]
        index = np.where(index >= 0, new[np.maximum(index, 0)] if len(new) else index, -1)
        return SpanTable(tuple(s for s, k in zip(self.spans, keep, strict=True) if k), frames[keep], index,
                         {name: rows[keep] for name, rows in self.features.items()})

    def extend(self, n_frames: int) -> SpanTable:
        """Lengthened to ``n_frames`` by repeating the last frame's span (as streams repeat their last frame)."""
        extra = n_frames - self.n_frames
        if extra <= 0 or self.n_frames == 0:
            return self
        last = int(self.index[-1])
        frames = self.frames.copy()
        if last >= 0:
            frames[last, 1] = n_frames
        return replace(self, frames=frames, index=np.concatenate([self.index, np.full(extra, last)]))


@dataclass
class TextSpans:
    """A batch's text spans as one table (torch tensors on the batch's device).

    ``spans``: the ``S`` spans of every row; ``row (S,)``: the batch row each belongs to; ``frames (S, 2)``:
    the ``[start, end)`` frames it covers in that row; ``index (B, T)``: per frame the span in force
    (into ``spans``; -1 where none); ``features``: per text stream ``(S, C)``, one row of the stream's
    features per span (standardized as the stream: ``word-tokens`` ids as they are). Long tensors but
    ``features`` (float32)."""

    spans: tuple[TextSpan, ...]
    row: Any
    frames: Any
    index: Any
    features: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def stack(cls, tables: Sequence[SpanTable], device: Any = None) -> TextSpans:
        """One row per table (all over the same frames), spans numbered row after row."""
        import torch

        lengths = {t.n_frames for t in tables}
        if len(lengths) > 1:
            raise ValueError(f"span tables over different frame counts cannot share a batch: {sorted(lengths)}")
        counts = [len(t.spans) for t in tables]
        offsets = np.cumsum([0, *counts[:-1]])
        index = np.stack([np.where(t.index >= 0, t.index + off, -1) for t, off in zip(tables, offsets, strict=True)])
        widths: dict[str, int] = {}
        for t in tables:
            for name, rows in t.features.items():
                widths.setdefault(name, rows.shape[1])
        features = {name: np.concatenate([np.asarray(t.features.get(name, np.zeros((len(t.spans), w))), np.float32)
                                          for t in tables]) for name, w in widths.items()}
        frames = np.concatenate([t.frames for t in tables]) if tables else np.zeros((0, 2), np.int64)

        def tensor(x: np.ndarray) -> Any:
            return torch.from_numpy(np.ascontiguousarray(x)).to(device)

        return cls(tuple(s for t in tables for s in t.spans),
                   tensor(np.repeat(np.arange(len(tables)), counts).astype(np.int64)),
                   tensor(frames.reshape(-1, 2).astype(np.int64)), tensor(index.astype(np.int64)),
                   {name: tensor(rows) for name, rows in features.items()})

    def crop(self, start: int, stop: int | None = None) -> TextSpans:
        """Frames ``[start, stop)`` of every row, with the spans that cover at least one of them."""
        stop = self.index.shape[1] if stop is None else min(stop, self.index.shape[1])
        frames = (self.frames - start).clamp(0, max(stop - start, 0))
        keep = frames[:, 1] > frames[:, 0]
        index = self.index[:, start:stop]
        if len(self.spans):
            new = keep.long().cumsum(0) - 1
            index = new[index.clamp(min=0)].where(index >= 0, index)
        return TextSpans(tuple(s for s, k in zip(self.spans, keep.tolist(), strict=True) if k), self.row[keep],
                         frames[keep], index, {name: rows[keep] for name, rows in self.features.items()})

    def pad(self, after: int) -> TextSpans:
        """``after`` more frames in every row, each in the span of the row's last frame (as streams are padded)."""
        import torch

        if after <= 0 or self.index.shape[1] == 0:
            return self
        length = self.index.shape[1]
        last = self.index[:, -1]
        frames = self.frames.clone()
        frames[last[last >= 0], 1] = length + after
        index = torch.cat([self.index, last[:, None].expand(-1, after)], dim=1)
        return TextSpans(self.spans, self.row, frames, index, dict(self.features))
