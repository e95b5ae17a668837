"""A numba kernel for one peephole-LSTM chain (one direction of madmom's LSTMLayer), compiled once and cached.

The gate nonlinearities use an ``exp`` built from a polynomial and an exponent written straight
into the bits of a double, so the per-step loops vectorise; numba's NumPy error model (no Python
division checks) keeps branches out of them. They are evaluated in float64 and rounded once, like
a correctly rounded float32 ``expf``: the forget gate multiplies the cell state at every step, so
float32 rounding in the gates would add up over a song (to ~1e-3 against madmom).
"""

from __future__ import annotations

import llvmlite.ir
import numpy as np

from .numba_cache import use_cache_dir

use_cache_dir()  # before numba's first import, so the compiled kernel lands in dance's cache

import numba  # noqa: E402
from numba.core import types  # noqa: E402
from numba.extending import intrinsic  # noqa: E402

_KERNEL = {"cache": True, "fastmath": True, "error_model": "numpy"}


@intrinsic
def _float64_from_bits(typingctx, bits):
    """The double whose IEEE-754 bit pattern is the int64 ``bits``."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], llvmlite.ir.DoubleType())

    return types.float64(types.int64), codegen


@numba.njit(inline="always", **_KERNEL)
def _exp(x):  # pragma: no cover - compiled
    """``exp(x)`` in float64 arithmetic that vectorises: ``2**n * e**r`` with ``|r| <= ln(2)/2``,
    ``e**r`` by its Taylor series to ``r**7`` (relative error below 6e-9, far below float32's
    rounding) and ``2**n`` written as the exponent field of a double."""
    x = min(max(x, -87.0), 87.0)
    n = np.floor(x * 1.4426950408889634 + 0.5)
    r = x - n * 0.6931471805599453
    p = 1 / 5040
    p = p * r + 1 / 720
    p = p * r + 1 / 120
    p = p * r + 1 / 24
    p = p * r + 1 / 6
    p = p * r + 0.5
    p = p * r + 1.0
    p = p * r + 1.0
    return p * _float64_from_bits((np.int64(n) + np.int64(1023)) << np.int64(52))


@numba.njit(inline="always", **_KERNEL)
def _sigmoid(x):  # pragma: no cover - compiled
    """The logistic function, in float64."""
    return 1.0 / (1.0 + _exp(-x))


@numba.njit(inline="always", **_KERNEL)
def _tanh(x):  # pragma: no cover - compiled
    """``tanh(x) = 2 sigmoid(2x) - 1``, in float64."""
    return 2.0 * _sigmoid(2.0 * x) - 1.0


@numba.njit(nogil=True, **_KERNEL)
def lstm_sequence(pre, w_rec, peep, reverse, out):  # pragma: no cover - compiled
    """Run one peephole-LSTM chain over a whole sequence, from the end when ``reverse``.

    ``pre (T, 4H)`` holds each step's input projection plus bias, gates ordered i, f, c, o;
    ``w_rec (H, 4H)`` the recurrent weights; ``peep (3, H)`` the peepholes of gates i, f, o. The
    hidden states go to ``out (T, H)`` (a column block of the layer's output). Gates i and f see
    the previous cell state, gate o the new one, as in madmom. ``fastmath`` only reorders float32
    sums and products of finite values; results stay within about 1e-5 of madmom's.
    """
    steps, four_h = pre.shape
    hidden = four_h // 4
    p_i, p_f, p_o = peep[0], peep[1], peep[2]
    h = np.zeros(hidden, dtype=np.float32)
    c = np.zeros(hidden, dtype=np.float32)
    gates = np.empty(four_h, dtype=np.float32)
    for s in range(steps):
        t = steps - 1 - s if reverse else s
        for k in range(four_h):
            gates[k] = pre[t, k]
        for j in range(hidden):
            hj = h[j]
            for k in range(four_h):
                gates[k] += hj * w_rec[j, k]
        for j in range(hidden):
            gi = _sigmoid(np.float64(gates[j] + c[j] * p_i[j]))
            gf = _sigmoid(np.float64(gates[hidden + j] + c[j] * p_f[j]))
            c[j] = c[j] * gf + _tanh(np.float64(gates[2 * hidden + j])) * gi
        for j in range(hidden):  # a second pass over j, so that each loop vectorises
            go = _sigmoid(np.float64(gates[3 * hidden + j] + c[j] * p_o[j]))
            h[j] = _tanh(np.float64(c[j])) * go
            out[t, j] = h[j]
