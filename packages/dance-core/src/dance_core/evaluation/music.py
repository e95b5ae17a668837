"""Music beats for the beat metrics: annotation files, dance-audio's tracker, or onset peaks.

For a song ``NAME`` in the music folder, the first source that exists wins:

1. ``NAME.beats``: a beat annotation (one beat per line, the time in seconds first, as madmom's
   and most MIR datasets' ``.beats`` files; ``dance evaluate`` writes none, it only reads them).
2. The audio file ``NAME.<suffix>`` read by a registered audio reader, with beats from the
   registered beat tracker (``beats=True``: dance-audio's ``beats``; its ``flux`` tracker by default,
   licence-clean, which agrees with madmom's on the fixture songs at phase-locking 0.95-0.99 where the
   ``librosa`` tracker puts two of the four songs' beats between madmom's; ``dance evaluate --tracker``).
3. Otherwise a documented fallback: peaks of the spectral-flux onset strength of core's
   ``energy`` features (log-compressed, above its 1 s moving average), at least ``MIN_GAP`` apart.
   These are onsets, not a tracked beat grid: on music with a steady pulse (the synthetic click
   tracks) they coincide with the beats; on real music they are a proxy, reported as such.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d

from dance_core.errors import DataError
from dance_core.media import Audio
from dance_core.registry import Registry

ONSET_FPS = 100.0
WINDOW_SECONDS = 0.023  # STFT window of the onset envelope (about 23 ms at any sample rate)
MIN_GAP = 0.25  # seconds between two fallback beats (240 bpm at most)
_SAMPLE_SUFFIX = re.compile(r"-\d+$")


def read_beats_file(path: Path) -> np.ndarray:
    """Beat times (s) from a ``.beats`` annotation; malformed lines are a DataError with the line."""
    times = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        try:
            times.append(float(line.split()[0]))
        except ValueError:
            raise DataError(f"{path}:{n}: not a beat time: {line!r}") from None
    return np.sort(np.asarray(times, dtype=np.float64))


def onset_envelope(audio: Audio, fps: float = ONSET_FPS) -> np.ndarray:
    """Spectral-flux onset strength per frame at ``fps`` (core's ``energy`` extractor's last column)."""
    from dance_core.components.energy import EnergyFeatures
    from dance_core.media import FeatureInputs

    n_fft = 2 ** int(round(np.log2(WINDOW_SECONDS * audio.rate)))
    extractor = EnergyFeatures(n_fft=n_fft, bands=[200.0, 2000.0], log_floor=1e-6)
    n = audio.n_frames(fps)
    envelope = extractor.extract(FeatureInputs(n, audio), fps)[:, -1].astype(np.float64)
    edge = int(np.ceil(n_fft / 2 / audio.rate * fps)) + 1
    envelope[:edge] = np.median(envelope)  # the flux of the zero padding before the song is not an onset
    return envelope


def novelty(envelope: np.ndarray, fps: float) -> np.ndarray:
    """Log-compressed onset strength above its 1 s moving average (half-wave rectified).

    The compression keeps a few loud events (a crash, a section change) from hiding every other
    onset, and the moving average removes slow loudness changes.
    """
    x = np.asarray(envelope, dtype=np.float64)
    positive = x[x > 0]
    if len(positive) == 0:
        return np.zeros_like(x)
    x = np.log1p(x / np.median(positive))
    return np.maximum(x - uniform_filter1d(x, max(1, int(round(fps))), mode="nearest"), 0.0)


def onset_peaks(envelope: np.ndarray, fps: float, min_gap: float = MIN_GAP) -> np.ndarray:
    """Times of strong onsets: local maxima of the novelty above its standard deviation,
    strongest first, none closer than ``min_gap`` seconds to a stronger one."""
    x = novelty(envelope, fps)
    if len(x) < 3 or np.ptp(x) <= 0:
        return np.zeros(0)
    is_peak = np.zeros(len(x), dtype=bool)
    is_peak[1:-1] = (x[1:-1] >= x[:-2]) & (x[1:-1] > x[2:])
    candidates = np.flatnonzero(is_peak & (x > x.std()))
    kept: list[int] = []
    gap = min_gap * fps
    for i in candidates[np.argsort(-x[candidates], kind="stable")]:
        if all(abs(i - k) >= gap for k in kept):
            kept.append(int(i))
    return np.sort(np.asarray(kept, dtype=np.float64)) / fps


def audio_beats(audio: Audio, registry: Registry, tracker: str = "flux") -> tuple[np.ndarray, str]:
    """Beat times of an audio signal and the name of the method that found them: the registered beat
    tracker (the extractor registered with ``beats=True``, dance-audio's ``beats``, ``tracker`` as its
    option), else onset peaks."""
    from dance_core.data.beat_tracking import TRACK_FPS, beat_tracker, tracked_beats

    entry = beat_tracker(registry)
    if entry is not None:
        beats, _ = tracked_beats(audio, registry, tracker)
        return beats / TRACK_FPS, f"'{entry.name}' extractor ({tracker} tracker)"
    return onset_peaks(onset_envelope(audio), ONSET_FPS), "energy onset peaks (fallback)"


def song_stem(clip_name: str) -> list[str]:
    """Song names a motion file may belong to: its own stem, then without a ``-<sample>`` suffix."""
    stripped = _SAMPLE_SUFFIX.sub("", clip_name)
    return [clip_name] if stripped == clip_name else [clip_name, stripped]


def find_audio(music_dir: Path, stem: str, audio_suffixes: set[str]) -> Path | None:
    """The audio file ``stem.<suffix>`` in ``music_dir`` that a registered reader reads, if any."""
    for path in sorted(music_dir.glob(f"{glob_escape(stem)}.*")):
        if path.suffix.lower() in audio_suffixes:
            return path
    return None


def find_song(music_dir: Path, clip_name: str, audio_suffixes: set[str]) -> Path | None:
    """The ``.beats`` file or audio file in ``music_dir`` that belongs to a clip, if any."""
    for stem in song_stem(clip_name):
        beats = music_dir / f"{stem}.beats"
        if beats.is_file():
            return beats
        audio = find_audio(music_dir, stem, audio_suffixes)
        if audio is not None:
            return audio
    return None


def glob_escape(name: str) -> str:
    """Escape glob metacharacters in a file stem."""
    return re.sub(r"([\[\]*?])", r"[\1]", name)
