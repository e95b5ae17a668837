"""A persistent numba cache, set before librosa (and so numba) is first imported."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """``$NUMBA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/dance/numba`` (``~/.cache/dance/numba``)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "dance" / "numba"


def import_librosa():
    """Import librosa with numba's on-disk cache enabled, so compiled kernels survive the process."""
    if "NUMBA_CACHE_DIR" not in os.environ:
        path = cache_dir()
        try:
            path.mkdir(parents=True, exist_ok=True)
            os.environ["NUMBA_CACHE_DIR"] = str(path)
        except OSError:  # a read-only home: numba then compiles in memory, as before
            pass
    try:
        import librosa
    except ImportError:
        from dance_core.errors import PluginError

        raise PluginError("librosa is not installed: pip install 'dance-audio'") from None
    return librosa
