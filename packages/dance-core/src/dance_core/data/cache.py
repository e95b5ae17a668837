"""A feature cache on disk, keyed by the audio file's content hash and the extractors' configuration.

Entries are ``<key>.npz`` files (no pickle) holding every stream of one song at full length; a
second epoch or run, or another recipe with the same features, reads them instead of recomputing.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.atomic import atomic_path

VERSION = 1


def file_digest(path: str | Path, chunk: int = 1 << 20) -> str:
    """SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


class FeatureCache:
    """Feature arrays stored under ``folder`` by key."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        self.hits = 0
        self.misses = 0

    def key(self, audio_path: str | Path, config: dict[str, Any]) -> str:
        """The entry key: content hash of the audio plus a hash of the (JSON) extractor config."""
        blob = json.dumps({"v": VERSION, "config": config}, sort_keys=True, default=str)
        return f"{file_digest(audio_path)[:32]}-{hashlib.sha256(blob.encode()).hexdigest()[:16]}"

    def get(self, key: str) -> dict[str, np.ndarray] | None:
        """The stored streams, or None (a damaged entry counts as missing)."""
        path = self.folder / f"{key}.npz"
        if not path.exists():
            self.misses += 1
            return None
        try:
            with np.load(path, allow_pickle=False) as f:
                out = {name: np.asarray(f[name]) for name in f.files}
        except (OSError, ValueError, zipfile.BadZipFile):
            self.misses += 1
            return None
        self.hits += 1
        return out

    def put(self, key: str, streams: dict[str, np.ndarray]) -> None:
        """Store streams atomically."""
        with atomic_path(self.folder / f"{key}.npz") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **streams)
