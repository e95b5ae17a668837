"""Makes madmom 0.16.1 (the only release) import and run on Python >= 3.10 and NumPy 2.

Three things break: ``madmom.processors`` imports ``collections.MutableSequence`` (moved to
``collections.abc``), madmom uses the removed aliases ``np.float``/``np.int``/... , and the DBN
downbeat tracker calls ``np.asarray`` on a list of ``(path, log_prob)`` pairs, a ragged array that
NumPy >= 1.24 refuses. :func:`import_madmom` restores the first two (as the builtins they always
were) and gives the downbeat module a NumPy whose ``asarray`` builds such lists as object arrays.
"""

from __future__ import annotations

import collections
import collections.abc
import types
import warnings

import numpy as np

INSTALL_HINT = (
    "madmom is not installed: pip install cython 'setuptools<81' && "
    "pip install --no-build-isolation madmom  (or: pip install 'dance-audio[madmom]')"
)
_ALIASES = {"float": float, "int": int, "complex": complex, "bool": bool, "object": object, "str": str}
_patched = False


class _RaggedTolerantNumpy(types.ModuleType):
    """NumPy, except that ``asarray`` of a ragged list gives an object array (NumPy < 1.24 did)."""

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def asarray(a, *args, **kwargs):
        """``np.asarray``; a ragged nested list becomes an object array instead of an error."""
        try:
            return np.asarray(a, *args, **kwargs)
        except ValueError:
            if args or "dtype" in kwargs:
                raise
            return np.asarray(a, dtype=object)


def _patch_environment() -> None:
    global _patched
    if _patched:
        return
    for name in ("MutableSequence", "MutableMapping", "Mapping", "Sequence", "Iterable"):
        if not hasattr(collections, name):
            setattr(collections, name, getattr(collections.abc, name))
    for name, value in _ALIASES.items():
        if name not in np.__dict__:
            setattr(np, name, value)
    _patched = True


def madmom_available() -> bool:
    """Whether madmom is installed (without importing it)."""
    import importlib.util

    return importlib.util.find_spec("madmom") is not None


def import_madmom():
    """Import madmom with the compatibility fixes applied; a missing madmom is a PluginError."""
    from dance_core import PluginError

    if not madmom_available():
        raise PluginError(INSTALL_HINT)
    _patch_environment()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # madmom imports the deprecated pkg_resources
        import madmom
        import madmom.features.beats
        import madmom.features.downbeats as downbeats
    if not isinstance(downbeats.np, _RaggedTolerantNumpy):
        downbeats.np = _RaggedTolerantNumpy("numpy")
    return madmom
