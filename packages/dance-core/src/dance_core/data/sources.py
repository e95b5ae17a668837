"""What datasets yield (``ClipSource``) and what training uses (``Clip``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dance_core.media import Audio, TextSpan
from dance_core.protocols import MotionData
from dance_core.spans import SpanTable


@dataclass
class ClipSource:
    """One dance: its motion, its music (in memory or as a file) and optional timed text."""

    name: str
    motion: MotionData
    audio: Audio | None = None
    audio_path: str | None = None
    texts: tuple[TextSpan, ...] = ()
    meta: dict = field(default_factory=dict)


@dataclass
class Clip:
    """Motion and feature streams cropped to one common frame count at the recipe's fps, and the
    clip's text spans over those frames (a ``SpanTable``; None for clips made without one)."""

    name: str
    motion: np.ndarray
    streams: dict[str, np.ndarray]
    song: str = ""  # clips of one song (e.g. a mirrored copy) stay on one side of the split
    spans: SpanTable | None = None

    def __post_init__(self) -> None:
        self.song = self.song or self.name

    def __len__(self) -> int:
        return len(self.motion)
