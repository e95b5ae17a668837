"""``madmom-downbeat``: madmom's beat and downbeat activations at 100 fps, resampled to the recipe's fps."""

from __future__ import annotations

from typing import Any

import numpy as np

from dance_core import Audio, DataError, FeatureInputs

from .memo import LastAudioMemo
from .timing import resample, retime

RATE, NATIVE_FPS = 44100, 100.0
_activations = LastAudioMemo()


def activations(audio: Audio, backend: str = "port") -> np.ndarray:
    """``(T100, 2)`` beat and downbeat activations at 100 fps from the port, or from madmom itself when
    ``backend`` is ``"madmom"`` (computed once for the last audio seen)."""
    return _activations.get(audio, backend, lambda: _compute(audio, backend))


def _compute(audio: Audio, backend: str) -> np.ndarray:
    y = resample(audio.samples, audio.rate, RATE)
    if backend != "madmom":
        from .downbeat_net import downbeat_activations

        return downbeat_activations(y)
    from .madmom_compat import import_madmom

    import_madmom()
    from madmom.audio.signal import Signal
    from madmom.features.downbeats import RNNDownBeatProcessor

    return np.asarray(RNNDownBeatProcessor()(Signal(y, sample_rate=RATE)), dtype=np.float32)


def resample_activation(x: np.ndarray, src_fps: float, n_frames: int, fps: float) -> np.ndarray:
    """Resample a ``(T, D)`` activation from ``src_fps`` to ``n_frames`` frames at ``fps``.

    Upsampling interpolates linearly at times i / fps. Downsampling takes, for each target frame,
    the maximum over the source frames nearest to it (times within half a target frame of i / fps),
    so a beat peak between two target frames keeps its height instead of being skipped or halved.
    """
    if fps >= src_fps or len(x) == 0:
        return retime(x, src_fps, n_frames, fps)
    owner = np.floor(np.arange(len(x)) * fps / src_fps + 0.5).astype(np.int64)  # nearest target frame
    out = np.full((n_frames, x.shape[1]), -np.inf, dtype=np.float64)
    keep = owner < n_frames
    np.maximum.at(out, owner[keep], x[keep])
    empty = ~np.isfinite(out[:, 0])
    if empty.any():  # target frames past the source's end hold its value
        out[empty] = retime(x, src_fps, n_frames, fps)[empty]
    return out.astype(np.float32)


class DownbeatFeatures:
    """Two columns: beat and downbeat activation of madmom's RNNDownBeatProcessor."""

    def __init__(self, backend: str = "port"):
        self.backend = backend

    def dim(self) -> int:
        """Beat and downbeat."""
        return 2

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """``(n_frames, 2)`` float32 activations in [0, 1]."""
        if inputs.audio is None:
            raise DataError("madmom-downbeat needs audio")
        act = activations(inputs.audio, self.backend)
        return resample_activation(act, NATIVE_FPS, inputs.n_frames, fps)


def build(config: Any, **_: Any) -> DownbeatFeatures:
    """Build the ``madmom-downbeat`` extractor."""
    return DownbeatFeatures(config.backend)
