"""Our own lossless motion format: ``values (T, D)``, ``fps`` and ``channels`` in an NPZ."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import atomic_path
from dance_core.errors import DataError
from dance_core.protocols import MotionData


class NpzFormat:
    """Reads and writes ``.npz`` motion files without pickle."""

    def __init__(self, compress: bool = True):
        self.compress = compress

    def read(self, path: str | Path) -> MotionData:
        """Load values, fps and channel names."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as f:
                raw = f["values"]
                if raw.dtype.kind not in "fiu":  # complex, bool, text, structured: never cast quietly
                    raise DataError(f"{path}: values: {raw.dtype} numbers; motion must be real numbers "
                                    "(float or integer)")
                values = np.asarray(raw, dtype=np.float32)
                fps_raw = np.asarray(f["fps"])
                if fps_raw.size != 1 or fps_raw.dtype.kind not in "fiu":
                    raise DataError(f"{path}: fps: expected one real number, got {fps_raw.dtype} of shape "
                                    f"{fps_raw.shape}")
                fps = float(fps_raw.reshape(()))
                channels = [str(c) for c in f["channels"]] if "channels" in f else None
        except FileNotFoundError:
            raise DataError(f"{path}: motion file not found") from None
        except KeyError as exc:
            raise DataError(f"{path}: not a dance motion NPZ (missing {exc})") from None
        except (OSError, ValueError, TypeError, EOFError, zipfile.BadZipFile) as exc:
            raise DataError(f"{path}: corrupt motion NPZ: {exc}") from None
        if values.ndim != 2:
            raise DataError(f"{path}: values must be (frames, channels), got {values.shape}")
        if not np.isfinite(fps) or fps <= 0 or fps > 10000:
            raise DataError(f"{path}: fps: must be a positive frame rate, got {fps:g}")
        if channels is not None and len(channels) != values.shape[1]:
            raise DataError(f"{path}: channels: {len(channels)} names for {values.shape[1]} value columns")
        return MotionData(values, fps, channels)

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write atomically."""
        arrays: dict[str, Any] = {
            "values": np.asarray(motion.values, dtype=np.float32),
            "fps": np.float64(motion.fps),
        }
        if motion.channels is not None:
            arrays["channels"] = np.asarray(list(motion.channels), dtype=str)
        save = np.savez_compressed if self.compress else np.savez
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            save(fh, **arrays)


def build(config: Any = None, **_: Any) -> NpzFormat:
    """Build the ``npz`` format."""
    return NpzFormat(compress=getattr(config, "compress", True))
