"""Beat and downbeat tracking and the ``beats`` extractor: one-hot beat and downbeat frames and the phase
within beat and bar.

Three trackers: ``flux`` (the default: a bar-pointer HMM over beat phase and tempo on dance-audio's
own spectral-flux activation, :mod:`.flux_beats`; follows tempo changes, no model files),
``librosa`` (our equal implementation of librosa's dynamic-programming tracker, one global tempo,
no model files) and ``madmom`` (madmom's DBN, reimplemented, on the downbeat RNN, which reads
madmom's network weights, licensed CC BY-NC-SA 4.0, non-commercial). madmom's files are read only
when asked for by name, or by ``auto`` (madmom when installed, else ``flux``), itself an opt-in.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dance_core import Audio, DataError, FeatureInputs, PluginError

from .meter import detect_meter
from .timing import event_phase, events_to_onehot, resample

LIBROSA_RATE, LIBROSA_FFT, LIBROSA_HOP, LIBROSA_MELS = 22050, 2048, 512, 128


@dataclass(frozen=True)
class Beats:
    """Beat times in seconds and each beat's position in its bar (1 = downbeat)."""

    times: np.ndarray
    positions: np.ndarray

    @property
    def downbeats(self) -> np.ndarray:
        """Times of the beats that start a bar."""
        return self.times[self.positions == 1]


def track_madmom(audio: Audio, beats_per_bar: list[int], min_bpm: float, max_bpm: float) -> Beats:
    """madmom's DBN downbeat tracker (our exact reimplementation, :mod:`.dbn`) on the ported RNN's
    activations; madmom itself is not imported, only its installed network weights are read."""
    from .madmom_compat import INSTALL_HINT, madmom_available

    if not madmom_available():
        raise PluginError(INSTALL_HINT)
    from .dbn import DBNDownBeatTracker
    from .downbeat import NATIVE_FPS, activations

    act = activations(audio)
    dbn = DBNDownBeatTracker(beats_per_bar=list(beats_per_bar), min_bpm=min_bpm, max_bpm=max_bpm, fps=NATIVE_FPS)
    result = dbn(act)
    return Beats(result[:, 0], result[:, 1].astype(np.int64))


def track_librosa(audio: Audio, beats_per_bar: list[int], min_bpm: float, max_bpm: float) -> Beats:
    """librosa's dynamic-programming beat tracker (our equal reimplementation, :mod:`.rhythm`) on the
    mean-over-mel-bands onset envelope; bars start on the beat phase with the most onset energy."""
    from .rhythm import beat_track, onset_strength
    from .spectral import mel_filterbank, power_to_db
    from .stft import stft

    y = resample(audio.samples, audio.rate, LIBROSA_RATE)
    power = np.abs(stft(y, LIBROSA_FFT, LIBROSA_HOP)) ** 2
    db = power_to_db(power @ mel_filterbank(LIBROSA_RATE, LIBROSA_FFT, LIBROSA_MELS).T, top_db=80.0)
    onset = onset_strength(db, LIBROSA_FFT, LIBROSA_HOP, aggregate=np.mean)
    _, frames = beat_track(onset, LIBROSA_RATE / LIBROSA_HOP, start_bpm=float(np.sqrt(min_bpm * max_bpm)))
    times = frames * LIBROSA_HOP / LIBROSA_RATE
    strength = onset[frames] if len(frames) else np.zeros(0)
    bar = detect_meter(onset, times, LIBROSA_RATE / LIBROSA_HOP, beats_per_bar)
    return Beats(times, bar_positions(strength, bar))


def bar_positions(strength: np.ndarray, bar: int) -> np.ndarray:
    """Positions 1..``bar`` of beats with onset ``strength``: bars start on the beat phase (modulo
    ``bar``) whose beats have the most onset energy on average."""
    offset = int(np.argmax([strength[k::bar].mean() if len(strength[k::bar]) else 0.0 for k in range(bar)]))
    return ((np.arange(len(strength)) - offset) % bar + 1).astype(np.int64)


def track_flux(audio: Audio, beats_per_bar: list[int], min_bpm: float, max_bpm: float) -> Beats:
    """The bar-pointer HMM on dance-audio's bass-weighted spectral flux (:mod:`.flux_beats`): tempo
    may change from beat to beat; the meter among ``beats_per_bar`` from the beats' rhythm patterns
    (:mod:`.meter`), bars starting on the beat phase with the most onset energy."""
    from .flux_beats import FPS, track_times

    times, env = track_times(audio.samples, audio.rate, min_bpm, max_bpm)
    frames = np.round(times * FPS).astype(np.int64)
    strength = np.array([env[max(0, f - 2) : f + 3].max() for f in frames]) if len(frames) else np.zeros(0)
    return Beats(times, bar_positions(strength, detect_meter(env, times, FPS, beats_per_bar)))


TRACKERS = ("flux", "librosa", "madmom", "auto")
DEFAULT_TRACKER = "flux"


def track_beats(
    audio: Audio, tracker: str = DEFAULT_TRACKER, beats_per_bar=(3, 4), min_bpm: float = 55.0,
    max_bpm: float = 160.0,
) -> Beats:
    """Beats of a song by ``tracker``: ``flux`` (default, no model files, follows tempo changes),
    ``librosa`` (no model files, one tempo), ``madmom`` (reads madmom's non-commercial weights), or
    ``auto`` (an opt-in: madmom when installed, else flux)."""
    from .madmom_compat import madmom_available

    if tracker not in TRACKERS:
        raise PluginError(f"beat tracker {tracker!r}: expected one of {', '.join(TRACKERS)}")
    if not 0 < min_bpm < max_bpm:
        raise PluginError(f"beat tracker tempo range {min_bpm}-{max_bpm} BPM: expected 0 < min_bpm < max_bpm")
    if tracker == "madmom" or (tracker == "auto" and madmom_available()):
        return track_madmom(audio, list(beats_per_bar), min_bpm, max_bpm)
    if tracker == "librosa" or (tracker == "auto" and DEFAULT_TRACKER == "librosa"):
        return track_librosa(audio, list(beats_per_bar), min_bpm, max_bpm)
    return track_flux(audio, list(beats_per_bar), min_bpm, max_bpm)


class BeatFeatures:
    """Six columns: beat one-hot, downbeat one-hot, sin and cos of the beat phase and of the bar phase."""

    #: 2: bars of the detected meter (3 or 4 beats, :mod:`.meter`) instead of always the longest
    revision = 2

    def __init__(self, tracker: str, beats_per_bar: list[int], min_bpm: float, max_bpm: float):
        self.tracker, self.beats_per_bar = tracker, list(beats_per_bar)
        self.min_bpm, self.max_bpm = min_bpm, max_bpm

    def dim(self) -> int:
        """Two one-hots and two (sin, cos) phase pairs."""
        return 6

    def streaming(self, fps: float, rate: int):
        """The same columns live (``dance live``): :class:`.online_beats.OnlineBeats`, the flux tracker's
        forward pass, whichever tracker is configured (the columns mean the same; madmom's network and
        librosa's dynamic program need the whole song)."""
        from .online_beats import OnlineBeats

        return OnlineBeats(fps, rate, self.beats_per_bar, self.min_bpm, self.max_bpm)

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """``(n_frames, 6)`` float32; each beat marks the frame nearest its time."""
        if inputs.audio is None:
            raise DataError("beats features need audio")
        beats = track_beats(inputs.audio, self.tracker, self.beats_per_bar, self.min_bpm, self.max_bpm)
        n = inputs.n_frames
        beat_phase = 2 * np.pi * event_phase(beats.times, n, fps)
        bar_phase = 2 * np.pi * event_phase(beats.downbeats, n, fps)
        cols = [
            events_to_onehot(beats.times, n, fps),
            events_to_onehot(beats.downbeats, n, fps),
            np.sin(beat_phase),
            np.cos(beat_phase),
            np.sin(bar_phase),
            np.cos(bar_phase),
        ]
        return np.stack(cols, axis=1).astype(np.float32)


def build(config: Any, **_: Any) -> BeatFeatures:
    """Build the ``beats`` extractor."""
    return BeatFeatures(config.tracker, config.beats_per_bar, config.min_bpm, config.max_bpm)
