"""Standardization statistics over the training split, stored with the model as tensors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dance_core.data.sources import Clip

MIN_STD = 1e-4


@dataclass
class Standardizer:
    """Per-channel mean and standard deviation."""

    mean: np.ndarray
    std: np.ndarray

    @classmethod
    def fit(cls, arrays: list[np.ndarray]) -> Standardizer:
        """Statistics over the frames of all arrays; constant channels get a std of 1."""
        stacked = np.concatenate(arrays, axis=0).astype(np.float64)
        mean = stacked.mean(axis=0)
        std = stacked.std(axis=0)
        std = np.where(std < MIN_STD, 1.0, std)
        return cls(mean.astype(np.float32), std.astype(np.float32))

    def apply(self, x: np.ndarray) -> np.ndarray:
        """Standardize."""
        return ((x - self.mean) / self.std).astype(np.float32)

    def invert(self, x: np.ndarray) -> np.ndarray:
        """Undo the standardization."""
        return (x * self.std + self.mean).astype(np.float32)


@dataclass
class NormStats:
    """Statistics of the motion and of every feature stream."""

    motion: Standardizer
    streams: dict[str, Standardizer]

    @classmethod
    def fit(cls, clips: list[Clip], categorical: dict[str, np.ndarray] | None = None) -> NormStats:
        """Fit on training clips; ``categorical`` channels (ids, per stream a boolean mask) are left as they are."""
        names = clips[0].streams.keys()
        streams = {n: Standardizer.fit([c.streams[n] for c in clips]) for n in names}
        for name, mask in (categorical or {}).items():
            if name in streams and mask.any():
                streams[name].mean[mask] = 0.0
                streams[name].std[mask] = 1.0
        return cls(Standardizer.fit([c.motion for c in clips]), streams)

    def apply(self, clip: Clip) -> Clip:
        """A standardized copy of a clip (its span table's rows standardized as their streams)."""
        return Clip(
            clip.name,
            self.motion.apply(clip.motion),
            {n: self.streams[n].apply(v) for n, v in clip.streams.items()},
            clip.song,
            None if clip.spans is None else clip.spans.map_features(self.apply_rows),
        )

    def apply_rows(self, stream: str, rows: np.ndarray) -> np.ndarray:
        """Rows of a stream's features (a span table's) standardized as the stream."""
        return self.streams[stream].apply(rows) if stream in self.streams else rows

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Flat ``norm.<part>.<mean|std>`` arrays for a safetensors file."""
        out = {"norm.motion.mean": self.motion.mean, "norm.motion.std": self.motion.std}
        for name, s in self.streams.items():
            out[f"norm.stream.{name}.mean"] = s.mean
            out[f"norm.stream.{name}.std"] = s.std
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> NormStats:
        """Inverse of :meth:`to_arrays`."""
        streams = {}
        for key in arrays:
            if key.startswith("norm.stream.") and key.endswith(".mean"):
                name = key[len("norm.stream.") : -len(".mean")]
                streams[name] = Standardizer(arrays[key], arrays[f"norm.stream.{name}.std"])
        motion = Standardizer(arrays["norm.motion.mean"], arrays["norm.motion.std"])
        return cls(motion, streams)
