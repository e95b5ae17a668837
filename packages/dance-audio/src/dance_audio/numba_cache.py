"""A persistent numba cache for dance-audio's compiled kernels, set before numba is first imported."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """``$NUMBA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/dance/numba`` (``~/.cache/dance/numba``)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "dance" / "numba"


def use_cache_dir() -> None:
    """Point numba at :func:`cache_dir` (unless ``$NUMBA_CACHE_DIR`` is set); call before importing numba."""
    if "NUMBA_CACHE_DIR" not in os.environ:
        path = cache_dir()
        try:
            path.mkdir(parents=True, exist_ok=True)
            os.environ["NUMBA_CACHE_DIR"] = str(path)
        except OSError:  # a read-only home: numba then compiles in memory, as before
            pass
