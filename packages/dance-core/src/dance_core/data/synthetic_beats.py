"""The ``synthetic-beats`` dataset: click-track music with known beats and a beat-locked dancer.

Each song has a tempo, a start phase and a random sequence of moves, one per bar of four beats.
Every joint oscillates around its rest position with the beat phase, so the motion is a function
of the music's beat phase and the current move: learnable, and checkable against known beats.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from dance_core.data.sources import ClipSource
from dance_core.media import Audio, TextSpan, frame_count
from dance_core.protocols import MotionData

MOVES = ("bounce", "sway", "clap", "twist")
BEATS_PER_BAR = 4


def click_track(beats: np.ndarray, seconds: float, rate: int, rng: np.random.Generator) -> np.ndarray:
    """Decaying tone bursts on the beats (higher and louder on downbeats) over a quiet drone."""
    pieces = list(click_chunks(beats, seconds, rate, rng))
    return np.concatenate(pieces) if pieces else np.zeros(0, np.float32)


def click_chunks(beats: np.ndarray, seconds: float, rate: int, rng: np.random.Generator,
                 chunk: int = 1 << 20) -> Iterator[np.ndarray]:
    """:func:`click_track` in pieces of ``chunk`` samples (the same samples, one piece in memory at a time)."""
    n = int(round(seconds * rate))
    notes = rng.choice([110.0, 130.8, 146.8, 164.8, 196.0], size=2, replace=False)
    burst_t = np.arange(int(0.12 * rate)) / rate
    tones = [(0.6 if down else 0.35) * np.sin(2 * np.pi * (1600.0 if down else 900.0) * burst_t)
             * np.exp(-burst_t / 0.03) for down in (False, True)]
    starts = np.round(np.asarray(beats, np.float64) * rate).astype(np.int64)
    for s in range(0, n, chunk):
        e = min(n, s + chunk)
        t = np.arange(s, e) / rate
        audio = 0.04 * np.sin(2 * np.pi * notes[0] * t) + 0.03 * np.sin(2 * np.pi * notes[1] * t)
        for k in np.flatnonzero((starts < e) & (starts + len(burst_t) > s) & (starts >= 0)):
            tone, start = tones[int(k % BEATS_PER_BAR == 0)], int(starts[k])
            lo, hi = max(start, s), min(e, start + len(tone))
            audio[lo - s:hi - s] += tone[lo - start:hi - start]
        audio += 0.003 * rng.standard_normal(e - s)
        yield audio.astype(np.float32)


class SyntheticBeats:
    """The ``synthetic-beats`` dataset (deterministic given its seed)."""

    def __init__(self, config, fps: float):
        self.config = config
        self.fps = fps
        shape_rng = np.random.default_rng([config.seed, 1_000_003])
        j = config.joints
        angle = 2 * np.pi * np.arange(j) / j
        self.rest = np.stack([0.4 * np.cos(angle), 1.0 + 0.3 * np.sin(angle), np.zeros(j)], axis=1)
        self.amplitude = shape_rng.normal(0.0, 0.12, size=(len(MOVES), j, 3))
        self.harmonic = np.array([1.0, 0.5, 2.0, 1.0])[: len(MOVES)]
        self.phase = shape_rng.uniform(0, 2 * np.pi, size=(len(MOVES), j, 1))
        self.channels = [f"joint{i}.{axis}" for i in range(j) for axis in "xyz"]

    def song(self, index: int) -> ClipSource:
        """Song ``index``: audio, beat times, moves and the dancer's motion."""
        cfg = self.config
        rng = np.random.default_rng([cfg.seed, index])
        bpm = rng.uniform(*cfg.bpm)
        period = 60.0 / bpm
        offset = rng.uniform(0, period)
        beats = np.arange(offset, cfg.seconds, period)
        n_bars = int(np.ceil(len(beats) / BEATS_PER_BAR)) + 2
        moves = rng.integers(0, len(MOVES), size=n_bars)
        audio = click_track(beats, cfg.seconds, cfg.sample_rate, rng)
        n = frame_count(cfg.seconds, self.fps)
        t = np.arange(n) / self.fps
        phase = (t - offset) / period  # beats elapsed since the first beat
        bar = np.clip(np.floor(phase / BEATS_PER_BAR).astype(int) + 1, 0, n_bars - 1)
        into_bar = phase / BEATS_PER_BAR - np.floor(phase / BEATS_PER_BAR)
        blend = np.clip((into_bar - 0.875) / 0.125, 0.0, 1.0)[:, None, None]  # last half beat
        nxt = np.minimum(bar + 1, n_bars - 1)
        pose = (1 - blend) * self._pose(moves[bar], phase) + blend * self._pose(moves[nxt], phase)
        motion = (self.rest[None] + pose).reshape(n, -1).astype(np.float32)
        texts = tuple(
            TextSpan(
                MOVES[moves[b]],
                max(0.0, offset + (b - 1) * BEATS_PER_BAR * period),
                min(cfg.seconds, offset + b * BEATS_PER_BAR * period),
            )
            for b in range(n_bars)
            if offset + (b - 1) * BEATS_PER_BAR * period < cfg.seconds and offset + b * BEATS_PER_BAR * period > 0
        )
        return ClipSource(
            name=f"synthetic-{index:03d}",
            motion=MotionData(motion, self.fps, self.channels),
            audio=Audio(audio, cfg.sample_rate),
            texts=texts,
            meta={"bpm": float(bpm), "beats": beats.tolist()},
        )

    def _pose(self, move: np.ndarray, phase: np.ndarray) -> np.ndarray:
        wave = np.sin(2 * np.pi * self.harmonic[move][:, None, None] * phase[:, None, None] + self.phase[move])
        return self.amplitude[move] * wave

    def clips(self) -> list[ClipSource]:
        """Every song."""
        return [self.song(i) for i in range(self.config.songs)]


def build(config: Any, *, fps: float, **_: Any) -> SyntheticBeats:
    """Build the ``synthetic-beats`` dataset at the recipe's fps."""
    return SyntheticBeats(config, fps)
