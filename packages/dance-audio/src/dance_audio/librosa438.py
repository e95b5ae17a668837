"""``librosa-438``: the DanceRevolution / Bailando / TM2D music features, without librosa.

Per frame, in this order (column 53 is the beat one-hot, as Bailando's beat-align score expects):
MFCC 20 | MFCC delta 20 | constant-Q chroma 12 | onset strength 1 | beat one-hot 1 | tempogram 384.
As in the reference code the audio is resampled to ``hop_length * fps`` Hz (15360 Hz at 30 fps) and
every librosa call keeps its defaults (``n_fft=2048``, 128 mels, ``width=3`` deltas, chroma on the
harmonic part, onset strength with a median over mel bands of the percussive part, tempogram window
384), so that ``center=True`` frames fall exactly at times i / fps.

This module no longer imports librosa (nor scipy.signal / ndimage / stats): it recomputes the same
pipeline with dance_audio's own pieces (:mod:`.stft`, :mod:`.hpss`, :mod:`.tuning`, :mod:`.cqt`,
:mod:`.cepstrum`, :mod:`.rhythm`), with float32 FFTs where librosa's are float64. Against librosa
0.11's calls on real music: MFCC, deltas, onset strength and tempogram agree to ~1e-5 of each
block's largest value, chroma to ~1e-6 after the per-frame max normalisation (near-silent frames,
~80 dB down, can move by up to ~1e-3: the normalisation magnifies rounding), and the HPSS masks,
tuning estimate and beat frames are the same (``tests/test_librosa_parts.py``). One shortcut: the
percussive part's STFT is taken as ``STFT(y) - STFT(harmonic)`` (STFTs are linear and the two soft
masks sum to 1), which saves an inverse and a forward STFT and differs from librosa's by rounding.

``backend: librosa`` (:class:`LibrosaBackend`, the ``dance-audio[librosa]`` extra) makes the same
librosa calls instead, on the same resampled signal, for whoever wants librosa's own numbers.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any

import numpy as np

from dance_core import DataError, FeatureInputs, PluginError

from .cepstrum import delta, mfcc
from .cqt import C1, chroma_cqt
from .hpss import hpss_masks
from .rhythm import beat_track, onset_strength, tempogram
from .spectral import mel_filterbank, power_to_db
from .stft import istft, stft
from .threads import one_blas_thread
from .timing import fit_frames, resample
from .tuning import estimate_tuning

CQT_FMIN = C1  # librosa's default lowest constant-Q bin
MFCC, CHROMA = 20, 12
CHROMA_BINS_PER_OCTAVE = 36
TOP_DB = 80.0
LIBROSA_HINT = "librosa-438 with backend: librosa needs librosa: pip install 'dance-audio[librosa]'"


class Librosa438:
    """MFCC, MFCC delta, chroma, onset, beat one-hot and tempogram: 438 values per frame."""

    def __init__(self, hop_length: int = 512, n_fft: int = 2048, n_mels: int = 128, tempogram_window: int = 384):
        self.hop = hop_length
        self.n_fft = n_fft
        self.n_mels = n_mels
        self.win = tempogram_window

    def dim(self) -> int:
        """20 + 20 + 12 + 1 + 1 + tempogram window (438 by default)."""
        return 2 * MFCC + CHROMA + 2 + self.win

    def rate(self, fps: float) -> int:
        """The analysis sample rate: one hop per frame."""
        rate = self.hop * fps
        if abs(rate - round(rate)) > 1e-6:
            raise DataError(f"librosa-438: hop_length * fps = {rate} Hz is not a whole sample rate")
        return int(round(rate))

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """``(n_frames, 438)`` float32 features at times i / fps.

        Silent or very short input (padded to one FFT window) gives finite features: no tuning to
        estimate (0 is used), chroma and tempogram frames without energy left at 0, no beats.
        """
        if inputs.audio is None:
            raise DataError("librosa-438 needs audio")
        return fit_frames(self.features(inputs.audio.samples, inputs.audio.rate, fps), inputs.n_frames)

    def features(self, samples: np.ndarray, rate: int, fps: float) -> np.ndarray:
        """``(1 + len(y) // hop_length, 438)`` float32 features of the samples resampled to ``hop * fps``.

        The work runs on two threads of its own, so BLAS is held to one thread meanwhile
        (:func:`.threads.one_blas_thread`).
        """
        with one_blas_thread():
            return self._features(samples, rate, fps)

    def _signal(self, samples: np.ndarray, rate: int, fps: float) -> tuple[np.ndarray, int]:
        """The samples at the analysis rate, padded to at least one FFT window (very short clips)."""
        sr = self.rate(fps)
        y = resample(samples, rate, sr)
        if len(y) < self.n_fft:
            y = np.pad(y, (0, self.n_fft - len(y)))
        return y, sr

    def _octaves(self, sr: int) -> int:
        """Constant-Q octaves above C1 that fit under 0.45 x the sample rate (at most 7, librosa's default)."""
        return int(min(7, np.floor(np.log2(0.45 * sr / CQT_FMIN))))

    def _features(self, samples: np.ndarray, rate: int, fps: float) -> np.ndarray:
        y, sr = self._signal(samples, rate, fps)
        spec = stft(y, self.n_fft, self.hop)
        magnitude = np.abs(spec)
        mel_basis = _mel_basis(sr, self.n_fft, self.n_mels)
        mel = (magnitude**2) @ mel_basis
        cepstra = mfcc(power_to_db(mel, ref=mel.max(), top_db=TOP_DB), MFCC)

        harmonic_mask, _ = hpss_masks(magnitude)
        harmonic = istft(spec * harmonic_mask, self.hop, len(y))
        harmonic_spec = stft(harmonic, self.n_fft, self.hop)  # and the percussive part's: spec - it

        with ThreadPoolExecutor(1) as pool:  # chroma and rhythm are independent: overlap them
            chroma_job = pool.submit(self._chroma, harmonic, harmonic_spec, sr)
            percussive_mel = np.abs(spec - harmonic_spec) ** 2 @ mel_basis
            onset = onset_strength(power_to_db(percussive_mel, top_db=TOP_DB), self.n_fft, self.hop)
            _, beats = beat_track(onset, sr / self.hop)
            beat = np.zeros_like(onset)
            beat[beats] = 1.0
            rhythm = tempogram(onset, self.win, np.float32)
            chroma = chroma_job.result()

        return _stack(cepstra, delta(cepstra, 3), chroma, onset, beat, rhythm)

    def _chroma(self, harmonic: np.ndarray, harmonic_spec: np.ndarray, sr: int) -> np.ndarray:
        """Constant-Q chroma of the harmonic part, tuned by the peaks of its spectrogram."""
        tuning = estimate_tuning(np.abs(harmonic_spec), sr, self.n_fft, bins_per_octave=CHROMA_BINS_PER_OCTAVE)
        return chroma_cqt(harmonic, sr, self.hop, tuning, self._octaves(sr), CHROMA_BINS_PER_OCTAVE, CHROMA)


class LibrosaBackend(Librosa438):
    """The same 438 values from librosa's own calls (the DanceRevolution reference code's, with this
    extractor's ``hop_length``, ``n_fft``, ``n_mels`` and tempogram window), on the same resampled signal."""

    def _features(self, samples: np.ndarray, rate: int, fps: float) -> np.ndarray:
        librosa = import_librosa()
        y, sr = self._signal(samples, rate, fps)
        stft_args = {"n_fft": self.n_fft, "hop_length": self.hop}
        mel = librosa.feature.melspectrogram(y=y, sr=sr, n_mels=self.n_mels, **stft_args)
        cepstra = librosa.feature.mfcc(S=librosa.power_to_db(mel, ref=np.max, top_db=TOP_DB), n_mfcc=MFCC)
        harmonic, percussive = librosa.effects.hpss(y, **stft_args)
        tuning = librosa.estimate_tuning(y=harmonic, sr=sr, bins_per_octave=CHROMA_BINS_PER_OCTAVE, **stft_args)
        chroma = librosa.feature.chroma_cqt(
            y=harmonic, sr=sr, hop_length=self.hop, tuning=tuning, n_chroma=CHROMA,
            bins_per_octave=CHROMA_BINS_PER_OCTAVE, n_octaves=self._octaves(sr),
        )
        onset = librosa.onset.onset_strength(y=percussive, sr=sr, aggregate=np.median, n_mels=self.n_mels, **stft_args)
        _, beats = librosa.beat.beat_track(onset_envelope=onset, sr=sr, hop_length=self.hop)
        beat = np.zeros_like(onset)
        beat[beats] = 1.0
        rhythm = librosa.feature.tempogram(onset_envelope=onset, sr=sr, hop_length=self.hop, win_length=self.win)
        return _stack(cepstra.T, librosa.feature.delta(cepstra, width=3).T, chroma.T, onset, beat, rhythm.T)


def import_librosa():
    """librosa (its numba kernels cached like ours); a one-line PluginError naming the extra without it."""
    from .numba_cache import use_cache_dir

    use_cache_dir()
    try:
        import librosa
    except ImportError:
        raise PluginError(LIBROSA_HINT) from None
    return librosa


def _stack(cepstra, deltas, chroma, onset, beat, rhythm) -> np.ndarray:
    """The frames-first blocks side by side in the 438 layout, cut to the shortest, finite float32."""
    n = min(len(cepstra), len(chroma), len(onset), len(rhythm))
    feats = np.concatenate(
        [cepstra[:n], deltas[:n], chroma[:n], onset[:n, None], beat[:n, None], rhythm[:n]], axis=1
    )
    return np.nan_to_num(feats).astype(np.float32)


@lru_cache(maxsize=4)
def _mel_basis(rate: int, n_fft: int, n_mels: int) -> np.ndarray:
    """The ``(n_fft // 2 + 1, n_mels)`` mel filterbank, built once per setting (read-only)."""
    basis = np.ascontiguousarray(mel_filterbank(rate, n_fft, n_mels).T)
    basis.flags.writeable = False
    return basis


def build(config: Any, **_: Any) -> Librosa438:
    """Build the ``librosa-438`` extractor with its ``backend`` (``librosa`` checks that librosa imports)."""
    if getattr(config, "backend", "port") == "librosa":
        import_librosa()
        return LibrosaBackend(config.hop_length, config.n_fft, config.n_mels, config.tempogram_window)
    return Librosa438(config.hop_length, config.n_fft, config.n_mels, config.tempogram_window)
