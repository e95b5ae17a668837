"""Figures a person can read: music vs kinematic tempograms, beat timelines, per-clip freezing."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from dance_core.evaluation import beats as B
from dance_core.evaluation.freezing import frozen_mask, max_joint_speed
from dance_core.evaluation.tempogram import impulses, tempogram
from dance_core.protocols import JointClip


def _pyplot():
    from dance_core.render.frames import require_matplotlib

    require_matplotlib("`dance evaluate --plot` needs matplotlib: pip install 'dance-core[plots]'")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    from dance_core.atomic import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=path.suffix.lstrip(".") or "png")
    _pyplot().close(fig)
    return path


def plot_clip_beats(clip: JointClip, path: Path, onset: np.ndarray | None = None, onset_fps: float = 100.0) -> Path:
    """Music and kinematic tempograms over a timeline of joint speed, motion beats and music beats.

    The music novelty is the song's onset envelope when given, else impulses at its beats; the
    kinematic novelty is impulses at the hips beats weighted by the hips' vertical speed (as in
    Transflower's Figure 3).
    """
    plt = _pyplot()
    p, fps = np.asarray(clip.positions, dtype=np.float64), clip.fps
    n = len(p)
    music = B.beats_within(clip.music_beats, clip.duration)
    vy = B.hips_vertical_velocity(p, fps)
    hips = B.hips_beats(p, fps)
    kin_novelty = impulses(hips, n, fps, np.abs(vy[np.clip(np.round(hips * fps).astype(int), 0, n - 1)]))
    if onset is not None:
        music_novelty, music_fps = onset, onset_fps
    else:
        music_novelty, music_fps = impulses(music, n, fps), fps
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for ax, novelty, rate, title in (
        (axes[0], music_novelty, music_fps, "music tempogram" + (" (onsets)" if onset is not None else " (beats)")),
        (axes[1], kin_novelty, fps, "kinematic tempogram (hips beats)"),
    ):
        window = min(4.0, clip.duration / 2)
        tg, bpm, times = tempogram(novelty, rate, window_seconds=window)
        ax.pcolormesh(_edges(times, linear=True), _edges(bpm, linear=False), tg, cmap="magma", shading="flat")
        ax.set_yscale("log")
        ax.set_ylabel("bpm")
        ax.set_title(title)
    speed = B.mean_joint_speed(p) * fps
    t = np.arange(len(speed)) / fps
    ax = axes[2]
    ax.plot(t, speed, color="tab:blue", lw=1, label="mean joint speed (m/s)")
    motion = B.bailando_motion_beats(p, fps)
    ax.plot(motion, np.interp(motion, t, speed), "o", ms=4, color="tab:orange", label="motion beats (Bailando)")
    for k, b in enumerate(music):
        ax.axvline(b, color="tab:green", lw=0.8, alpha=0.7, label="music beats" if k == 0 else None)
    ax.plot(hips, np.zeros_like(hips), "^", ms=5, color="tab:red", label="hips beats (Transflower)")
    ax.set_xlabel("time (s)")
    ax.set_title(f"beat alignment: {clip.name}")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _edges(centres: np.ndarray, linear: bool) -> np.ndarray:
    """Cell edges around sorted centres (arithmetic or geometric midpoints)."""
    c = np.asarray(centres, dtype=np.float64)
    if len(c) == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5]) if linear else np.array([c[0] / 1.05, c[0] * 1.05])
    if linear:
        mid = (c[1:] + c[:-1]) / 2
        return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])
    mid = np.sqrt(c[1:] * c[:-1])
    return np.concatenate([[c[0] ** 2 / mid[0]], mid, [c[-1] ** 2 / mid[-1]]])


def plot_freezing(clips: Sequence[JointClip], path: Path, threshold: float = 0.015, min_seconds: float = 3.0) -> Path:
    """Per clip, a strip of frozen frames over time (red) and the clip's PFF."""
    plt = _pyplot()
    rows = max(1, len(clips))
    fig, (ax, bar) = plt.subplots(1, 2, figsize=(11, 1.0 + 0.35 * rows), gridspec_kw={"width_ratios": [4, 1]})
    pffs = []
    for k, clip in enumerate(clips):
        speed = max_joint_speed(np.asarray(clip.positions, dtype=np.float64), clip.fps)
        mask = frozen_mask(speed, clip.fps, threshold, min_seconds)
        pffs.append(100 * mask.mean() if len(mask) else 0.0)
        ax.broken_barh([(0, clip.duration)], (k - 0.4, 0.8), color="0.85")
        edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
        spans = [(s / clip.fps, (e - s) / clip.fps) for s, e in zip(edges[::2], edges[1::2], strict=True)]
        if spans:
            ax.broken_barh(spans, (k - 0.4, 0.8), color="tab:red")
    names = [c.name for c in clips]
    ax.set_yticks(range(len(names)), names, fontsize=7)
    ax.set_xlabel("time (s)")
    ax.set_title(f"frozen frames (max joint speed < {threshold:g} m/s for >= {min_seconds:g} s)")
    bar.barh(range(len(names)), pffs, color="tab:red")
    bar.set_yticks(range(len(names)), [])
    bar.set_xlim(0, 100)
    bar.set_xlabel("PFF (%)")
    for a in (ax, bar):
        a.invert_yaxis()
    fig.tight_layout()
    return _save(fig, path)


def write_plots(generated: Sequence[JointClip], out_dir: Path, max_clips: int = 4) -> list[Path]:
    """The freezing overview and beat figures for the first ``max_clips`` clips with music."""
    out_dir = Path(out_dir)
    written = [plot_freezing(generated, out_dir / "freezing.png")]
    with_music = [c for c in generated if c.music_beats is not None and len(c.positions) >= 3]
    for clip in with_music[:max_clips]:
        audio = clip.meta.get("audio")
        onset = _song_onsets(audio) if audio else None
        written.append(plot_clip_beats(clip, out_dir / f"beats-{clip.name}.png", onset))
    return written


def _song_onsets(song: str) -> np.ndarray:
    from dance_core.data.features import load_audio
    from dance_core.evaluation.music import ONSET_FPS, novelty, onset_envelope
    from dance_core.registry import get_registry

    return novelty(onset_envelope(load_audio(song, get_registry())), ONSET_FPS)
