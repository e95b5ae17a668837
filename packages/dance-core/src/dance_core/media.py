"""Plain containers for what features are computed from: audio samples and timed text."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Audio:
    """Mono float32 samples in [-1, 1] at ``rate`` Hz, and the file they came from."""

    samples: np.ndarray
    rate: int
    path: Path | None = None

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return len(self.samples) / self.rate

    def n_frames(self, fps: float) -> int:
        """Frames at ``fps`` under the alignment rule: ``ceil(duration * fps)``."""
        return frame_count(self.duration, fps)


@dataclass(frozen=True)
class TextSpan:
    """An instruction that applies from ``start`` to ``end`` seconds (``end=None``: to the end)."""

    text: str
    start: float = 0.0
    end: float | None = None


@dataclass(frozen=True)
class FeatureInputs:
    """What a feature extractor reads: audio and/or timed text, and the frame count to produce."""

    n_frames: int
    audio: Audio | None = None
    texts: tuple[TextSpan, ...] = field(default_factory=tuple)


def frame_count(duration: float, fps: float) -> int:
    """``ceil(duration * fps)``, robust to float noise (frame i describes time i / fps)."""
    return int(math.ceil(round(duration * fps, 6)))
