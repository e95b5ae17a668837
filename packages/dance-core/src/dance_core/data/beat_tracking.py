"""Beats and downbeats of a song from the registered beat tracker.

Core tracks no beats itself: the synthesizer's choreography and the beat metrics' music beats come from
the feature extractor registered with ``beats=True`` (dance-audio's ``beats``), found by that capability
rather than by its name. Its first two columns are beat and downbeat one-hot frames, and its ``tracker``
option picks the tracking method (``dance synth --tracker``, ``synthetic-dance``'s ``dance_to_tracker``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from dance_core.errors import PluginError
from dance_core.media import Audio, FeatureInputs

if TYPE_CHECKING:
    from dance_core.registry import Entry, Registry

#: the frame rate beats are tracked at
TRACK_FPS = 100.0


def beat_tracker(registry: Registry) -> Entry | None:
    """The feature extractor registered with ``beats=True`` (the first by name if several), or ``None``."""
    found = [entry for entry in registry.entries("feature") if entry.info.get("beats")]
    return found[0] if found else None


def tracked_beats(audio: Audio, registry: Registry, tracker: str = "flux") -> tuple[np.ndarray, np.ndarray]:
    """Beat and downbeat frame indices at ``TRACK_FPS`` from the registered beat tracker, its ``tracker``
    option set to ``tracker``. A ``PluginError`` when none is installed."""
    entry = beat_tracker(registry)
    if entry is None:
        raise PluginError("tracking beats needs a feature extractor registered with beats=True, such as "
                          "dance-audio's 'beats' (pip install dance-audio)")
    extractor = entry.build(entry.config_for({"tracker": tracker}))
    n = audio.n_frames(TRACK_FPS)
    cols = np.asarray(extractor.extract(FeatureInputs(n_frames=n, audio=audio), TRACK_FPS))
    return np.flatnonzero(cols[:, 0] > 0.5), np.flatnonzero(cols[:, 1] > 0.5)
