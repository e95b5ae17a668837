"""Audio files to mono float32 samples: soundfile (wav, flac, ogg, mp3), audioread as a fallback."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from dance_core import Audio, DataError, check_audio_path

SUFFIXES = (".wav", ".wave", ".flac", ".ogg", ".oga", ".mp3", ".aif", ".aiff")
SILENCE = 1e-4  # peak amplitude below which a file counts as silent
SHORT_SECONDS = 1.0


def _read_soundfile(path: Path) -> tuple[np.ndarray, int]:
    import soundfile as sf

    data, rate = sf.read(str(path), dtype="float32", always_2d=True)
    return data.mean(axis=1), int(rate)


def _read_audioread(path: Path) -> tuple[np.ndarray, int]:
    chunks = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # audioread imports aifc, audioop, sunau
        import audioread

        with audioread.audio_open(str(path)) as f:
            rate, channels = int(f.samplerate), int(f.channels)
            for buf in f:
                chunks.append(np.frombuffer(buf, "<i2"))
    pcm = np.concatenate(chunks) if chunks else np.zeros(0, "<i2")
    pcm = pcm[: len(pcm) // channels * channels].reshape(-1, channels)
    return pcm.astype(np.float32).mean(axis=1) / 32768.0, rate


class SoundFileReader:
    """Reads any format libsndfile knows; falls back to audioread (ffmpeg, GStreamer) for the rest."""

    def read(self, path: str | Path) -> Audio:
        """Samples mixed to mono float32 in [-1, 1] at the file's own rate."""
        path = check_audio_path(path)
        try:
            samples, rate = _read_soundfile(path)
        except Exception as first:  # libsndfile cannot decode it: try the system decoders
            try:
                samples, rate = _read_audioread(path)
            except Exception:
                reason = str(first).splitlines()[0] if str(first) else type(first).__name__
                raise DataError(f"{path}: cannot decode audio ({reason})") from None
        if len(samples) == 0:
            raise DataError(f"{path}: audio file holds no samples")
        if not np.all(np.isfinite(samples)):
            raise DataError(f"{path}: audio holds NaN or infinite samples")
        check_content(samples, rate, path)
        return Audio(np.ascontiguousarray(samples, dtype=np.float32), rate, path)


def check_content(samples: np.ndarray, rate: int, path: Path | None) -> None:
    """Warn (not fail) on silence and on very short clips: features stay well defined for both."""
    name = path if path is not None else "audio"
    if float(np.max(np.abs(samples))) < SILENCE:
        warnings.warn(f"{name}: audio is silent; features will be constant", stacklevel=3)
    if len(samples) / rate < SHORT_SECONDS:
        warnings.warn(f"{name}: audio is only {len(samples) / rate:.2f} s long", stacklevel=3)


def build(config: Any = None, **_: Any) -> SoundFileReader:
    """Build the ``soundfile`` reader."""
    return SoundFileReader()
