"""Musical time on uneven beats: a continuous beat coordinate for any list of beat times.

The synthetic dancer moves as a function of musical time (beats since the first downbeat). With a
drum machine that is ``(t - offset) / period``; with a live band or a tracked real song the beats
are uneven, so the coordinate is interpolated linearly between beat times and extrapolated with
the first and last intervals beyond them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dance_core.errors import DataError


@dataclass(frozen=True)
class BeatGrid:
    """Beat times (s, increasing), the beats per bar and which beat is the first downbeat."""

    times: np.ndarray
    beats_per_bar: int
    first_downbeat: int = 0

    @classmethod
    def from_positions(cls, times: np.ndarray, positions: np.ndarray) -> BeatGrid:
        """A grid from tracked beats and their positions in the bar (1 = downbeat); the meter is
        the most common bar length between downbeats."""
        times = np.asarray(times, np.float64)
        positions = np.asarray(positions, np.int64)
        if len(times) < 2:
            raise DataError(f"need at least 2 beats to dance to, found {len(times)}")
        down = np.flatnonzero(positions == 1)
        if len(down) >= 2:
            lengths, counts = np.unique(np.diff(down), return_counts=True)
            bar = int(lengths[np.argmax(counts)])
        else:
            bar = int(max(2, positions.max()))
        first = int(down[0]) if len(down) else 0
        return cls(times, min(max(bar, 2), 7), first)

    def __post_init__(self):
        if len(self.times) < 2 or np.any(np.diff(self.times) <= 0):
            raise DataError("beat times must be at least 2 and strictly increasing")

    def beat_at(self, t: np.ndarray) -> np.ndarray:
        """Beats since the first downbeat at times ``t`` (negative before it)."""
        t = np.asarray(t, np.float64)
        idx = np.arange(len(self.times), dtype=np.float64)
        b = np.interp(t, self.times, idx)
        first, last = self.times[1] - self.times[0], self.times[-1] - self.times[-2]
        b = np.where(t < self.times[0], (t - self.times[0]) / first, b)
        b = np.where(t > self.times[-1], len(self.times) - 1 + (t - self.times[-1]) / last, b)
        return b - self.first_downbeat

    def time_of(self, beat: np.ndarray | float) -> np.ndarray:
        """The inverse of :meth:`beat_at`: seconds at a beat coordinate."""
        b = np.asarray(beat, np.float64) + self.first_downbeat
        idx = np.arange(len(self.times), dtype=np.float64)
        t = np.interp(b, idx, self.times)
        first, last = self.times[1] - self.times[0], self.times[-1] - self.times[-2]
        t = np.where(b < 0, self.times[0] + b * first, t)
        return np.where(b > len(self.times) - 1, self.times[-1] + (b - len(self.times) + 1) * last, t)

    def bars(self, seconds: float) -> int:
        """Whole or partial bars from the first downbeat to ``seconds``."""
        return max(1, int(np.ceil(float(self.beat_at(seconds)) / self.beats_per_bar)))

    def downbeats(self) -> np.ndarray:
        """Times of the beats that start a bar."""
        return self.times[self.first_downbeat % self.beats_per_bar :: self.beats_per_bar]

    @property
    def bpm(self) -> float:
        """Median tempo in beats per minute."""
        return float(60.0 / np.median(np.diff(self.times)))
