"""A restricted unpickler: plain containers and NumPy arrays only, never arbitrary code."""

from __future__ import annotations

import io
import pickle
from pathlib import Path
from typing import Any

from dance_core.errors import DataError

#: (module, name) pairs a NumPy array or scalar pickle needs, across NumPy 1 and 2 module paths
ALLOWED = {
    ("builtins", n) for n in ("dict", "list", "tuple", "set", "frozenset", "bytearray", "bytes", "str", "int",
                              "float", "complex", "bool", "slice")
} | {
    (m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray") for n in ("_reconstruct", "scalar")
} | {
    ("numpy", "ndarray"), ("numpy", "dtype"), ("numpy.core.numeric", "_frombuffer"),
    ("numpy._core.numeric", "_frombuffer"), ("_codecs", "encode"),
}


class RestrictedUnpickler(pickle.Unpickler):
    """Refuses every global except those in :data:`ALLOWED`."""

    def find_class(self, module: str, name: str) -> Any:
        """Resolve an allowed global, or refuse."""
        if (module, name) in ALLOWED:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"refused to load {module}.{name}: only containers and NumPy arrays are allowed")


def safe_load(path: str | Path) -> Any:
    """Unpickle a file with :class:`RestrictedUnpickler`; any failure is a one-line ``DataError``."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{path}: motion file not found") from None
    try:
        return RestrictedUnpickler(io.BytesIO(data), encoding="latin1").load()
    except pickle.UnpicklingError as exc:
        raise DataError(f"{path}: {exc}") from None
    except (EOFError, ValueError, TypeError, AttributeError, ImportError, IndexError, KeyError) as exc:
        raise DataError(f"{path}: not a readable pickle ({type(exc).__name__}: {exc})") from None
