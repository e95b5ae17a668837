"""Keeping BLAS to one thread while dance-audio's own work runs (OpenBLAS's idle threads spin)."""

from __future__ import annotations

from contextlib import AbstractContextManager
from functools import lru_cache
from typing import Any

from threadpoolctl import ThreadpoolController


@lru_cache(maxsize=1)
def _controller() -> Any:
    """threadpoolctl's controller of the BLAS libraries loaded in this process."""
    return ThreadpoolController()


def one_blas_thread() -> AbstractContextManager:
    """A context in which BLAS runs single-threaded; the previous limits come back on exit.

    On a 2-core machine OpenBLAS's workers keep spinning after each product and take the core
    that the next step (an FFT, a numba kernel, another extractor) needs: with one BLAS thread the
    feature extractors run faster and use about half the CPU. The limit is process-wide while the
    context lasts.
    """
    return _controller().limit(limits=1, user_api="blas")
