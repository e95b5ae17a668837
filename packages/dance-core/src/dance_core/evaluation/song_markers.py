"""A song's markers for animators: beats and downbeats from the registered beat tracker, sections from the
sound (the synthetic dancer's section finder), and the dance's own foot contacts.

The beat tracker is the feature extractor registered with ``beats=True`` (dance-audio's ``beats``); without
one this is a one-line ``PluginError``, raised before anything is written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dance_core.motion.markers import Markers, contact_spans
from dance_core.motion.motion import Motion
from dance_core.registry import Registry


def song_markers(music: str | Path, registry: Registry, motion: Motion | None = None, start: float = 0.0,
                 tracker: str = "flux") -> Markers:
    """Beats, downbeats and sections of ``music`` (seconds from ``start`` into the song, the dance's first
    frame), and ``motion``'s foot contacts when given; events past the dance's end are dropped."""
    from dance_core.data.features import load_audio
    from dance_core.synth.choreograph import bar_features, find_sections, track_grid

    audio = load_audio(music, registry)
    grid = track_grid(audio, registry, tracker)
    n_bars = grid.bars(audio.duration)
    bar = grid.beats_per_bar
    sections = [(name, float(grid.time_of(a * bar)), float(grid.time_of(b * bar)))
                for name, a, b in find_sections(bar_features(audio, grid, n_bars))]
    end = motion.duration if motion is not None else audio.duration - start

    def inside(times: np.ndarray) -> list[float]:
        return [float(t) - start for t in times if 0.0 <= t - start <= end]

    timed = [(name, max(a - start, 0.0), min(b - start, end)) for name, a, b in sections]
    return Markers(inside(grid.times), inside(grid.downbeats()), [s for s in timed if s[2] > s[1]],
                   contact_spans(motion) if motion is not None else {})
