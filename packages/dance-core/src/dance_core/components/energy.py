"""Dependency-free music features: log band energies and spectral-flux onset strength."""

from __future__ import annotations

from typing import Any

import numpy as np

from dance_core.errors import DataError
from dance_core.media import FeatureInputs

CHUNK = 1024  # frames per STFT batch, to bound memory on long songs


class EnergyFeatures:
    """``len(bands) + 1`` log band energies plus one onset-strength channel per frame."""

    def __init__(self, n_fft: int, bands: list[float], log_floor: float):
        self.n_fft = n_fft
        self.edges = sorted(bands)
        self.log_floor = log_floor

    def dim(self) -> int:
        """Band energies and onset strength."""
        return len(self.edges) + 2

    def _spectra(self, samples: np.ndarray, rate: int, n_frames: int, fps: float) -> np.ndarray:
        half = self.n_fft // 2
        padded = np.pad(samples, (half, half + self.n_fft))
        window = np.hanning(self.n_fft).astype(np.float32)
        centers = np.round(np.arange(n_frames) * rate / fps).astype(np.int64)
        centers = np.minimum(centers, len(samples))
        out = np.empty((n_frames, half + 1), dtype=np.float32)
        offsets = np.arange(self.n_fft)
        for lo in range(0, n_frames, CHUNK):
            idx = centers[lo : lo + CHUNK, None] + offsets[None, :]
            out[lo : lo + CHUNK] = np.abs(np.fft.rfft(padded[idx] * window, axis=1))
        return out

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """Features for ``inputs.n_frames`` frames centred at times i / fps."""
        if inputs.audio is None:
            raise DataError("energy features need audio")
        audio = inputs.audio
        mag = self._spectra(audio.samples, audio.rate, inputs.n_frames, fps)
        freqs = np.fft.rfftfreq(self.n_fft, 1.0 / audio.rate)
        edges = [0.0, *self.edges, np.inf]
        power = mag**2
        bands = [
            power[:, (freqs >= lo) & (freqs < hi)].sum(axis=1) for lo, hi in zip(edges[:-1], edges[1:], strict=True)
        ]
        log_bands = np.log(np.stack(bands, axis=1) / self.n_fft + self.log_floor)
        log_mag = np.log1p(mag * 100.0)
        flux = np.zeros(inputs.n_frames, dtype=np.float32)
        flux[1:] = np.maximum(np.diff(log_mag, axis=0), 0.0).mean(axis=1)
        return np.concatenate([log_bands, flux[:, None]], axis=1).astype(np.float32)


def build(config: Any, **_: Any) -> EnergyFeatures:
    """Build the ``energy`` extractor."""
    return EnergyFeatures(config.n_fft, list(config.bands), config.log_floor)
