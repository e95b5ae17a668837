"""A PNG to check a song's features by eye: mel spectrogram, onset envelope, beats and downbeats."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from dance_core import Audio, PluginError

PLOT_FPS = 100.0
PLOT_HINT = "`dance features --plot` needs matplotlib: pip install 'dance-audio[plots]'"


def require_plotting() -> None:
    """matplotlib on the Agg backend; a one-line PluginError naming the extra when it is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise PluginError(PLOT_HINT) from None
    matplotlib.use("Agg", force=False)


def plot_song(audio: Audio, fps: float, out: Path) -> None:
    """Draw the 80-band log-mel, the onset envelope and the tracked beats (downbeats bold) to ``out``.

    The beats are those of dance-audio's default tracker (`flux`): no madmom file is read.
    """
    require_plotting()
    import matplotlib.pyplot as plt

    from dance_core import atomic_path

    from .beats import track_beats
    from .rhythm import spectral_flux
    from .spectral import log_mel

    rate = max(fps, PLOT_FPS)
    n = audio.n_frames(rate)
    db = log_mel(audio, n, rate, 80, 22050, 2048)
    onset = spectral_flux(db, np.mean)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        beats = track_beats(audio, "flux")
    t_end = n / rate
    fig, (ax_mel, ax_onset) = plt.subplots(2, 1, figsize=(12, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax_mel.imshow(
        db.T, origin="lower", aspect="auto", extent=(0, t_end, 0, 80), cmap="magma", vmin=db.max() - 80, vmax=db.max()
    )
    ax_mel.set_ylabel("mel band")
    ax_mel.set_title(
        f"{audio.path.name if audio.path else 'audio'}: {len(beats.times)} beats, {len(beats.downbeats)} downbeats"
    )
    ax_onset.plot(np.arange(n) / rate, onset, lw=0.8, color="black")
    ax_onset.set_ylabel("onset")
    ax_onset.set_xlabel("time (s)")
    for ax in (ax_mel, ax_onset):
        ax.vlines(beats.times, *ax.get_ylim(), color="cyan", lw=0.6, alpha=0.8)
        ax.vlines(beats.downbeats, *ax.get_ylim(), color="lime", lw=1.8)
    fig.tight_layout()
    with atomic_path(out, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
