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


def use_cache_dir() -> None:
    """Point numba at :func:`cache_dir` (unless ``$NUMBA_CACHE_DIR`` is set); call before importing numba."""
    if "NUMBA_CACHE_DIR" not in os.environ:
        path = cache_dir()
        try:
            path.mkdir(parents=True, exist_ok=True)
            os.environ["NUMBA_CACHE_DIR"] = str(path)
        except OSError:  # a read-only home: numba then compiles in memory, as before
            pass


def import_librosa():
    """Import librosa with numba's on-disk cache enabled, so compiled kernels survive the process."""
    use_cache_dir()
    try:
        import librosa
    except ImportError:
        from dance_core.errors import PluginError

        raise PluginError("librosa is not installed: pip install 'dance-audio'") from None
    _import_beat_with_cache()
    return librosa


def _import_beat_with_cache() -> None:
    """Import ``librosa.beat`` with every numba kernel cached on disk.

    librosa 0.11 declares one beat-tracking kernel (``__beat_local_score``) with ``cache=False``
    and eager signatures, so it is compiled again at every import, in every new process. It is
    a pure, fully typed function, so caching it is safe: ``numba.guvectorize`` is wrapped to
    force ``cache=True`` for the duration of this one import.
    """
    import sys

    if "librosa.beat" in sys.modules:
        return
    import numba

    original = numba.guvectorize

    def cached_guvectorize(*args, **kwargs):
        kwargs["cache"] = True
        return original(*args, **kwargs)

    numba.guvectorize = cached_guvectorize
    try:
        import librosa.beat  # noqa: F401
    finally:
        numba.guvectorize = original
