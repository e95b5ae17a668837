"""The extractor itself: RMS in a window centred on each frame's time, in dB."""

from __future__ import annotations

import numpy as np

from dance_core import FeatureInputs


class Loudness:
    """One channel: ``20 log10(rms)``, clipped below at ``floor_db``."""

    def __init__(self, window: float, floor_db: float):
        self.window = window
        self.floor_db = floor_db

    def dim(self) -> int:
        """One channel."""
        return 1

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """Loudness of the audio around times i / fps."""
        audio = inputs.audio
        half = max(1, int(self.window * audio.rate / 2))
        power = np.concatenate([[0.0], np.cumsum(audio.samples.astype(np.float64) ** 2)])
        centers = np.round(np.arange(inputs.n_frames) * audio.rate / fps).astype(int)
        lo = np.clip(centers - half, 0, len(audio.samples))
        hi = np.clip(centers + half, 0, len(audio.samples))
        mean = (power[hi] - power[lo]) / np.maximum(hi - lo, 1)
        db = 10 * np.log10(np.maximum(mean, 10 ** (self.floor_db / 10)))
        return db[:, None].astype(np.float32)


def build(config, **_) -> Loudness:
    """Build ``loudness`` from its config."""
    return Loudness(config.window, config.floor_db)
