"""A restricted unpickler: plain containers and NumPy arrays only, never arbitrary code.

Two foreign classes that SMPL body model files hold are read as inert stand-ins, never imported:
chumpy's ``Ch`` (its pickled state keeps the value as the NumPy array ``x``) and SciPy's
compressed-sparse-column matrix (``data``/``indices``/``indptr`` and a shape). Once the pickle is
loaded, each stand-in is replaced by a plain NumPy array (the sparse matrix made dense), checked.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.errors import DataError

_BUILTINS = ("dict", "list", "tuple", "set", "frozenset", "bytearray", "bytes", "str", "int", "float", "complex",
             "bool", "slice")
#: (module, name) pairs a NumPy array or scalar pickle needs, across NumPy 1 and 2 module paths (and the
#: ``__builtin__`` module of Python 2 pickles)
ALLOWED = {
    (m, n) for m in ("builtins", "__builtin__") for n in _BUILTINS
} | {
    (m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray") for n in ("_reconstruct", "scalar")
} | {
    ("numpy", "ndarray"), ("numpy", "dtype"), ("numpy.core.numeric", "_frombuffer"),
    ("numpy._core.numeric", "_frombuffer"), ("_codecs", "encode"),
}

#: the largest sparse matrix made dense (elements): SMPL's joint regressor has 24 x 6890
MAX_DENSE = 50_000_000


class _StandIn:
    """A foreign object read without its class: only its pickled state is kept."""

    state: Any = None

    def __setstate__(self, state: Any) -> None:
        self.state = state


class ChumpyArray(_StandIn):
    """Stands in for ``chumpy.ch.Ch``; becomes its array ``x``."""

    def array(self) -> np.ndarray:
        """The plain array this chumpy object holds."""
        x = self.state.get("x") if isinstance(self.state, dict) else None
        if isinstance(x, ChumpyArray):
            return x.array()
        if not isinstance(x, np.ndarray):
            raise pickle.UnpicklingError("a chumpy object holds no plain array (x); only plain Ch arrays are read")
        return x


class SparseCsc(_StandIn):
    """Stands in for SciPy's ``csc_matrix``/``csc_array``; becomes the dense array."""

    def array(self) -> np.ndarray:
        """The matrix as a dense array, after checking its compressed columns."""
        s = self.state if isinstance(self.state, dict) else {}
        shape = s.get("_shape", s.get("shape"))
        try:
            rows, cols = (int(v) for v in shape)
            data, indices, indptr = (np.asarray(s[k]) for k in ("data", "indices", "indptr"))
        except (TypeError, ValueError, KeyError):
            raise pickle.UnpicklingError("a sparse matrix without data, indices, indptr and a 2-d shape") from None
        if rows < 0 or cols < 0 or rows * cols > MAX_DENSE:
            raise pickle.UnpicklingError(f"a sparse matrix of shape ({rows}, {cols}) is too large to read")
        ok = (data.ndim == indices.ndim == indptr.ndim == 1 and len(indptr) == cols + 1
              and indices.dtype.kind in "iu" and indptr.dtype.kind in "iu" and data.dtype.kind in "biuf")
        ok = ok and int(indptr[0]) == 0 and int(indptr[-1]) == len(indices) == len(data)
        ok = ok and bool(np.all(np.diff(indptr) >= 0))
        ok = ok and (len(indices) == 0 or 0 <= int(indices.min()) <= int(indices.max()) < rows)
        if not ok:
            raise pickle.UnpicklingError(f"a sparse matrix ({rows}, {cols}) with inconsistent compressed columns")
        dense = np.zeros((rows, cols), np.float64)
        np.add.at(dense, (indices.astype(np.int64), np.repeat(np.arange(cols), np.diff(indptr))), data)
        return dense


#: foreign (module, name) -> the stand-in read in its place (SMPL model files: chumpy and SciPy, old and new paths)
STAND_INS: dict[tuple[str, str], type[_StandIn]] = {
    ("chumpy.ch", "Ch"): ChumpyArray,
    ("scipy.sparse.csc", "csc_matrix"): SparseCsc,
    ("scipy.sparse._csc", "csc_matrix"): SparseCsc,
    ("scipy.sparse._csc", "csc_array"): SparseCsc,
}


class RestrictedUnpickler(pickle.Unpickler):
    """Refuses every global except those in :data:`ALLOWED` and the inert :data:`STAND_INS`."""

    stand_ins = 0

    def find_class(self, module: str, name: str) -> Any:
        """Resolve an allowed global or a stand-in, or refuse."""
        if (module, name) in STAND_INS:
            self.stand_ins += 1
            return STAND_INS[module, name]
        if (module, name) in ALLOWED:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"refused to load {module}.{name}: only containers and NumPy arrays are allowed")


def _plain(obj: Any) -> Any:
    """``obj`` with every stand-in inside dicts, lists and tuples replaced by its array."""
    if isinstance(obj, (ChumpyArray, SparseCsc)):
        return obj.array()
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_plain(v) for v in obj]
    if isinstance(obj, tuple):
        return tuple(_plain(v) for v in obj)
    return obj


def safe_load(path: str | Path, what: str = "motion file") -> Any:
    """Unpickle a file with :class:`RestrictedUnpickler`; any failure is a one-line ``DataError``
    (``what`` names the file in the not-found message)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{path}: {what} not found") from None
    except IsADirectoryError:
        raise DataError(f"{path}: {what} is a folder, not a file") from None
    try:
        unpickler = RestrictedUnpickler(io.BytesIO(data), encoding="latin1")
        obj = unpickler.load()
        return _plain(obj) if unpickler.stand_ins else obj
    except pickle.UnpicklingError as exc:
        raise DataError(f"{path}: {exc}") from None
    except (EOFError, ValueError, TypeError, AttributeError, ImportError, IndexError, KeyError, RecursionError) as exc:
        raise DataError(f"{path}: not a readable pickle ({type(exc).__name__}: {exc})") from None
