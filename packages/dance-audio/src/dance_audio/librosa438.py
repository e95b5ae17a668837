"""``librosa-438``: the DanceRevolution / Bailando / TM2D music features.

Per frame, in this order (column 53 is the beat one-hot, as Bailando's beat-align score expects):
MFCC 20 | MFCC delta 20 | constant-Q chroma 12 | onset strength 1 | beat one-hot 1 | tempogram 384.
As in the reference code the audio is resampled to ``hop_length * fps`` Hz (15360 Hz at 30 fps) and
every librosa call keeps its defaults (``n_fft=2048``, 128 mels, ``width=3`` deltas, chroma on the
harmonic part, onset strength with a median over mel bands of the percussive part, tempogram window
384), so that ``center=True`` frames fall exactly at times i / fps.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.media import FeatureInputs

from .numba_cache import import_librosa
from .timing import fit_frames, resample

CQT_FMIN = 32.70319566257483  # C1, librosa's default
MFCC, CHROMA = 20, 12


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

        librosa's own warnings on silent or very short input (no pitch to estimate the tuning
        from, CQT windows longer than the clip) are silenced: the reader already warns once about
        such audio, and the features stay finite and well defined.
        """
        if inputs.audio is None:
            raise DataError("librosa-438 needs audio")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return self._extract(inputs, fps)

    def _extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        librosa = import_librosa()
        sr = self.rate(fps)
        y = resample(inputs.audio.samples, inputs.audio.rate, sr)
        need = self.n_fft  # very short clips: pad so every librosa call has a full window
        if len(y) < need:
            y = np.pad(y, (0, need - len(y)))
        mel = librosa.feature.melspectrogram(y=y, sr=sr, n_fft=self.n_fft, hop_length=self.hop, n_mels=self.n_mels)
        mfcc = librosa.feature.mfcc(S=librosa.power_to_db(mel, ref=np.max), n_mfcc=MFCC)
        delta = librosa.feature.delta(mfcc, width=3)
        stft = librosa.stft(y, n_fft=self.n_fft, hop_length=self.hop)
        harm_spec, perc_spec = librosa.decompose.hpss(stft)
        harmonic = librosa.istft(harm_spec, hop_length=self.hop, length=len(y))
        percussive = librosa.istft(perc_spec, hop_length=self.hop, length=len(y))
        octaves = int(min(7, np.floor(np.log2(0.45 * sr / CQT_FMIN))))
        chroma = librosa.feature.chroma_cqt(y=harmonic, sr=sr, hop_length=self.hop, n_chroma=CHROMA, n_octaves=octaves)
        onset = librosa.onset.onset_strength(y=percussive, sr=sr, hop_length=self.hop, aggregate=np.median)
        _, beats = librosa.beat.beat_track(onset_envelope=onset, sr=sr, hop_length=self.hop)
        beat = np.zeros_like(onset)
        beat[np.asarray(beats, dtype=np.int64)] = 1.0
        tempogram = librosa.feature.tempogram(onset_envelope=onset, sr=sr, hop_length=self.hop, win_length=self.win)
        n = min(mfcc.shape[1], chroma.shape[1], len(onset), tempogram.shape[1])
        feats = np.concatenate(
            [mfcc[:, :n], delta[:, :n], chroma[:, :n], onset[None, :n], beat[None, :n], tempogram[:, :n]], axis=0
        ).T
        return fit_frames(np.nan_to_num(feats).astype(np.float32), inputs.n_frames)


def build(config: Any, **_: Any) -> Librosa438:
    """Build the ``librosa-438`` extractor."""
    return Librosa438(config.hop_length, config.n_fft, config.n_mels, config.tempogram_window)
