"""The synthetic dancer choreographed to any music: tracked beats, sections from the sound, moves per section.

Beats and downbeats come from the registered beat tracker (dance-audio's ``beats`` extractor, see
:mod:`dance_core.data.beat_tracking`), so core needs no audio analysis of its own beyond a coarse
per-bar description used to find sections: loudness and the balance of low, middle and high
frequencies. Section boundaries sit where that description changes most (novelty between the bars
before and after), and each section is named by its loudness (quiet: intro, bridge or outro; loud:
chorus; else verse), which sets the preferences of :func:`~dance_core.synth.dancer.choose_moves`.
Several seeds give several valid dances to one song.
"""

from __future__ import annotations

import numpy as np

from dance_core.data.beat_tracking import TRACK_FPS, tracked_beats
from dance_core.errors import DataError
from dance_core.media import Audio, TextSpan
from dance_core.motion.motion import Motion
from dance_core.registry import Registry
from dance_core.synth.beat_grid import BeatGrid
from dance_core.synth.dancer import Style, choose_moves, dance

#: upper edges (Hz) of the bands of the per-bar description
BANDS = (150.0, 400.0, 1000.0, 2500.0, 6000.0)


def track_grid(audio: Audio, registry: Registry, tracker: str = "flux") -> BeatGrid:
    """Beats and downbeats of a song as a ``BeatGrid`` (see ``tracked_beats``)."""
    beats, downbeats = tracked_beats(audio, registry, tracker)
    down = set(downbeats.tolist())
    where = audio.path or "music"
    if len(beats) < 4:
        raise DataError(f"{where}: only {len(beats)} beats found; nothing to dance to")
    positions = np.zeros(len(beats), np.int64)
    count = 0
    for i, b in enumerate(beats):
        count = 1 if b in down or (i == 0 and not down) else count + 1
        positions[i] = count
    return BeatGrid.from_positions(beats / TRACK_FPS, positions)


def bar_features(audio: Audio, grid: BeatGrid, n_bars: int) -> np.ndarray:
    """``(n_bars, 1 + len(BANDS) + 1)``: log loudness and log band energies of each bar."""
    x = np.asarray(audio.samples, np.float64)
    rate = audio.rate
    edges = grid.time_of(np.arange(n_bars + 1) * grid.beats_per_bar)
    feats = np.zeros((n_bars, len(BANDS) + 2))
    for k in range(n_bars):
        a, b = (int(np.clip(round(e * rate), 0, len(x))) for e in edges[k : k + 2])
        seg = x[a:b]
        if len(seg) < 64:
            feats[k] = feats[k - 1] if k else -10.0
            continue
        spec = np.abs(np.fft.rfft(seg * np.hanning(len(seg)))) ** 2
        freqs = np.fft.rfftfreq(len(seg), 1.0 / rate)
        lo = 0.0
        for j, hi in enumerate((*BANDS, np.inf)):
            feats[k, j + 1] = np.log10(spec[(freqs >= lo) & (freqs < hi)].sum() / len(seg) + 1e-10)
            lo = hi
        feats[k, 0] = np.log10(np.mean(seg**2) + 1e-10)
    return feats


def find_sections(feats: np.ndarray, min_bars: int = 4, bars_per_section: int = 8) -> list[tuple[str, int, int]]:
    """Sections ``(name, first bar, end bar)`` from per-bar features: boundaries at the strongest
    novelty peaks (about one per ``bars_per_section`` bars, at least ``min_bars`` apart), names
    from loudness."""
    n = len(feats)
    if n < 2 * min_bars:
        return [("verse", 0, n)]
    z = (feats - feats.mean(0)) / (feats.std(0) + 1e-6)
    novelty = np.zeros(n)
    for k in range(min_bars, n - min_bars + 1):
        w = min(4, k, n - k)
        novelty[k] = np.linalg.norm(z[k : k + w].mean(0) - z[k - w : k].mean(0))
    cuts = [0]
    for k in np.argsort(-novelty, kind="stable"):
        if len(cuts) > n // bars_per_section or novelty[k] <= 0.25 * novelty.max():  # no cut on noise
            break
        if all(abs(int(k) - c) >= min_bars for c in cuts) and n - k >= min_bars:
            cuts.append(int(k))
    cuts = sorted(cuts) + [n]
    loud = np.array([feats[a:b, 0].mean() for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
    lo, hi = np.quantile(loud, [1 / 3, 2 / 3]) if len(loud) > 2 else (loud.min(), loud.max())
    sections = []
    for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:], strict=True)):
        if loud[i] >= hi and len(loud) > 1:
            name = "chorus"
        elif loud[i] <= lo and len(loud) > 2:
            name = "intro" if i == 0 else "outro" if i == len(loud) - 1 else "bridge"
        else:
            name = "verse"
        sections.append((name, a, b))
    return sections


def choreograph(audio: Audio, grid: BeatGrid, fps: float, rng: np.random.Generator
                ) -> tuple[Motion, tuple[TextSpan, ...], list[tuple[str, float, float]]]:
    """A dance to ``audio`` on ``grid``'s beats: motion, its text labels and the sections in seconds."""
    seconds = audio.duration
    n_bars = grid.bars(seconds)
    sections = find_sections(bar_features(audio, grid, n_bars))
    moves = choose_moves(sections, rng)
    motion, texts = dance(grid, moves, seconds, fps, Style.draw(rng))
    bar_s = grid.beats_per_bar
    timed = [(name, max(0.0, float(grid.time_of(a * bar_s))), min(seconds, float(grid.time_of(b * bar_s))))
             for name, a, b in sections]
    return motion, texts, timed
