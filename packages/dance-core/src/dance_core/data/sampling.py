"""Train/validation split by clip, and segment batches drawn by a per-step seeded generator."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from dance_core.data.sources import Clip
from dance_core.errors import DataError
from dance_core.spans import SpanTable, TextSpans


def split_clips(clips: list[Clip], val_fraction: float, seed: int) -> tuple[list[Clip], list[Clip]]:
    """Hold out whole songs for validation (with every clip of them); one song each side when possible."""
    songs = sorted({c.song for c in clips})
    order = np.random.default_rng([seed, 7]).permutation(len(songs))
    n_val = int(round(len(songs) * val_fraction))
    n_val = min(max(n_val, 1), len(songs) - 1) if val_fraction > 0 and len(songs) > 1 else 0
    held = {songs[i] for i in order[:n_val]}
    return [c for c in clips if c.song not in held], [c for c in clips if c.song in held]


@dataclass
class Batch:
    """Aligned segments: motion ``(B, L, D)``, streams ``{name: (B, L, C)}`` and their text spans (a
    ``TextSpans`` over the ``L`` frames; None when no clip carries a span table)."""

    motion: torch.Tensor
    streams: dict[str, torch.Tensor]
    spans: TextSpans | None = None


class SegmentSampler:
    """Batches of aligned segments; batch ``k`` depends only on (seed, k), so resuming replays it."""

    def __init__(self, clips: list[Clip], length: int, batch_size: int, seed: int, what: str = "training"):
        self.length = length
        self.batch_size = batch_size
        self.seed = seed
        self.clips = [c for c in clips if len(c) >= length]
        if not self.clips:
            longest = max((len(c) for c in clips), default=0)
            raise DataError(
                f"no {what} clip is long enough for segments of {length} frames "
                f"(longest has {longest}); use longer clips or smaller windows"
            )
        valid = np.array([len(c) - length + 1 for c in self.clips], dtype=np.float64)
        self.valid = valid.astype(np.int64)
        self.weights = valid / valid.sum()

    def windows(self) -> int:
        """How many distinct segments exist (the size of an epoch, in segments)."""
        return int(self.valid.sum())

    def batch(
        self, index: int, device: torch.device | str = "cpu", size: int | None = None, part: tuple[int, int] = (0, 1)
    ) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """Batch ``index``'s motion ``(B, L, D)`` and streams ``{name: (B, L, C)}`` (:meth:`draw`, without
        the text spans)."""
        drawn = self.draw(index, device, size, part)
        return drawn.motion, drawn.streams

    def draw(
        self, index: int, device: torch.device | str = "cpu", size: int | None = None, part: tuple[int, int] = (0, 1)
    ) -> Batch:
        """Batch ``index``: motion, streams and text spans of ``size`` segments (B, else the default).

        ``part=(k, n)``: the batch of ``B × n`` segments is drawn, and its ``k``-th run of ``B`` rows
        returned (one rank's share of a distributed batch: the ``n`` parts together are exactly the
        batch one process draws with ``size=B × n``)."""
        k, n = part
        size = size or self.batch_size
        rng = np.random.default_rng([self.seed, index])
        picks = rng.choice(len(self.clips), size=size * n, p=self.weights)
        starts = rng.integers(0, self.valid[picks])
        picks, starts = picks[k * size : (k + 1) * size], starts[k * size : (k + 1) * size]
        sl = [slice(int(s), int(s) + self.length) for s in starts]
        motion = np.stack([self.clips[p].motion[s] for p, s in zip(picks, sl, strict=True)])
        names = self.clips[0].streams.keys()
        pairs = list(zip(picks, sl, strict=True))
        streams = {n: torch.from_numpy(np.stack([self.clips[p].streams[n][s] for p, s in pairs])).to(device)
                   for n in names}
        return Batch(torch.from_numpy(motion).to(device), streams, self._spans(pairs, device))

    def _spans(self, pairs: list[tuple[Any, slice]], device: torch.device | str) -> TextSpans | None:
        """The segments' span tables as one batch table (a clip without one has no spans)."""
        if all(self.clips[p].spans is None for p, _ in pairs):
            return None
        empty = SpanTable.at((), self.length, 1.0)
        tables = [empty if self.clips[p].spans is None else self.clips[p].spans.crop(s.start, s.stop)
                  for p, s in pairs]
        return TextSpans.stack(tables, device)
