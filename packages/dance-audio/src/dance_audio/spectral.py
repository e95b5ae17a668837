"""``mel`` (log-mel bands) and ``onset`` (spectral flux of the log-mel): Transflower's 80 + 1.

Frames are cut at the exact sample ``round(i * rate / fps)`` (zero padded at both ends, a periodic
Hann window of ``n_fft`` samples centred there), so any fps works and frame i describes time i / fps.
Both extractors share one cached spectrogram when a stack asks for both on the same audio.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dance_core import Audio, DataError, FeatureInputs

from .memo import LastAudioMemo
from .rhythm import spectral_flux
from .stft import stft_at
from .threads import one_blas_thread
from .timing import resample

AMIN = 1e-10
#: seconds added to half a window for the look-ahead ``dance live`` waits for (a resampler's edge)
LIVE_MARGIN = 0.01
_log_mels = LastAudioMemo()


def _power_frames(y: np.ndarray, rate: int, n_frames: int, fps: float, n_fft: int) -> np.ndarray:
    centres = np.minimum(np.round(np.arange(n_frames) * rate / fps).astype(np.int64), len(y))
    return stft_at(y, centres, n_fft, power=True)


def hz_to_mel(hz: np.ndarray) -> np.ndarray:
    """Slaney's mel scale: linear (3 mels per 200 Hz) below 1 kHz, logarithmic above."""
    hz = np.asarray(hz, dtype=np.float64)
    log_part = 15.0 + np.log(np.maximum(hz, 1e-10) / 1000.0) / (np.log(6.4) / 27.0)
    return np.where(hz >= 1000.0, log_part, hz * 3.0 / 200.0)


def mel_to_hz(mel: np.ndarray) -> np.ndarray:
    """Inverse of :func:`hz_to_mel`."""
    mel = np.asarray(mel, dtype=np.float64)
    return np.where(mel >= 15.0, 1000.0 * np.exp((np.log(6.4) / 27.0) * (mel - 15.0)), mel * 200.0 / 3.0)


def mel_filterbank(rate: int, n_fft: int, n_mels: int, fmin: float = 0.0, fmax: float | None = None) -> np.ndarray:
    """``(n_mels, n_fft // 2 + 1)`` triangular filters on the Slaney mel scale, each of area ~1 in Hz.

    The same filters as ``librosa.filters.mel`` with its defaults (``htk=False, norm="slaney"``),
    built here so the mel and onset features need neither librosa nor numba at run time.
    """
    fmax = rate / 2.0 if fmax is None else float(fmax)
    freqs = np.fft.rfftfreq(n_fft, 1.0 / rate)
    edges = mel_to_hz(np.linspace(hz_to_mel(fmin), hz_to_mel(fmax), n_mels + 2))
    width = np.diff(edges)
    ramps = edges[:, None] - freqs[None, :]
    rising = -ramps[:-2] / width[:-1, None]
    falling = ramps[2:] / width[1:, None]
    weights = np.maximum(0.0, np.minimum(rising, falling))
    weights *= (2.0 / (edges[2:] - edges[:-2]))[:, None]
    return weights.astype(np.float32)


def power_to_db(power: np.ndarray, ref: float = 1.0, top_db: float | None = None) -> np.ndarray:
    """``10 log10(power / ref)`` with power floored at 1e-10 (and ``ref`` too), then, with ``top_db``,
    floored at ``top_db`` below the maximum: librosa's ``power_to_db``."""
    db = 10.0 * np.log10(np.maximum(power, AMIN))
    db -= 10.0 * np.log10(np.maximum(AMIN, ref))  # in ref's precision, as librosa
    if top_db is not None:
        db = np.maximum(db, db.max() - top_db)
    return db


def log_mel(
    audio: Audio,
    n_frames: int,
    fps: float,
    n_mels: int,
    rate: int,
    n_fft: int,
    fmin: float = 0.0,
    fmax: float | None = None,
) -> np.ndarray:
    """``(n_frames, n_mels)`` mel power in dB (re 1.0), cached for the last audio seen."""

    def compute() -> np.ndarray:
        y = resample(audio.samples, audio.rate, rate)
        basis = mel_filterbank(rate, n_fft, n_mels, fmin, fmax)
        with one_blas_thread():
            return power_to_db(_power_frames(y, rate, n_frames, fps, n_fft) @ basis.T)

    return _log_mels.get(audio, (n_frames, fps, n_mels, rate, n_fft, fmin, fmax), compute)


class MelFeatures:
    """``n_mels`` log-mel bands in dB (re 1.0, or re the song's loudest bin like Transflower)."""

    def __init__(self, n_mels: int, rate: int, n_fft: int, fmin: float, fmax: float | None, reference: str):
        self.n_mels, self.rate, self.n_fft = n_mels, rate, n_fft
        self.fmin, self.fmax, self.reference = fmin, fmax, reference
        #: seconds of audio past a frame's time its window reads (``dance live`` waits for them)
        self.lookahead = n_fft / 2 / rate + LIVE_MARGIN

    def dim(self) -> int:
        """The number of mel bands."""
        return self.n_mels

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """``(n_frames, n_mels)`` float32."""
        if inputs.audio is None:
            raise DataError("mel features need audio")
        db = log_mel(inputs.audio, inputs.n_frames, fps, self.n_mels, self.rate, self.n_fft, self.fmin, self.fmax)
        if self.reference == "max":
            db = db - db.max()
        return db.astype(np.float32)


class OnsetFeatures:
    """Spectral flux: the mean over mel bands of the positive dB increase since the previous frame."""

    def __init__(self, n_mels: int, rate: int, n_fft: int):
        self.n_mels, self.rate, self.n_fft = n_mels, rate, n_fft
        #: seconds of audio past a frame's time its window reads (``dance live`` waits for them)
        self.lookahead = n_fft / 2 / rate + LIVE_MARGIN

    def dim(self) -> int:
        """One onset-strength value per frame."""
        return 1

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """``(n_frames, 1)`` float32; frame 0 (nothing before it) is 0."""
        if inputs.audio is None:
            raise DataError("onset features need audio")
        db = log_mel(inputs.audio, inputs.n_frames, fps, self.n_mels, self.rate, self.n_fft)
        return spectral_flux(db, np.mean)[:, None]


def build_mel(config: Any, **_: Any) -> MelFeatures:
    """Build the ``mel`` extractor."""
    return MelFeatures(config.n_mels, config.sample_rate, config.n_fft, config.fmin, config.fmax, config.reference)


def build_onset(config: Any, **_: Any) -> OnsetFeatures:
    """Build the ``onset`` extractor."""
    return OnsetFeatures(config.n_mels, config.sample_rate, config.n_fft)
