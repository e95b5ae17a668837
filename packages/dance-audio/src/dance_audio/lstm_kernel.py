"""A numba kernel for a bidirectional peephole-LSTM ensemble (madmom's LSTMLayer), compiled once and cached."""

from __future__ import annotations

import math

import numpy as np

from .numba_cache import use_cache_dir

use_cache_dir()  # before numba's first import, so the compiled kernel lands in dance's cache

import numba  # noqa: E402

_POW2 = np.array([2.0**k for k in range(-127, 128)], dtype=np.float32)  # 2**n for n in -127..127
_ONE, _TWO = np.float32(1.0), np.float32(2.0)


@numba.njit(cache=True, inline="always", fastmath=True)
def _exp(x):  # pragma: no cover - compiled
    """``exp(x)`` in float32 arithmetic that vectorises (no libm call): ``2**n * e**r`` with
    ``|r| <= ln(2)/2`` and ``e**r`` by its Taylor series to ``r**7`` (relative error below 1e-7)."""
    x = min(max(x, np.float32(-87.0)), np.float32(87.0))
    n = math.floor(x * np.float32(1.4426950408889634) + np.float32(0.5))
    r = x - n * np.float32(0.6931471805599453)
    p = np.float32(1 / 5040)
    for coef in (1 / 720, 1 / 120, 1 / 24, 1 / 6, 1 / 2, 1.0, 1.0):
        p = p * r + np.float32(coef)
    return p * _POW2[int(n) + 127]


@numba.njit(cache=True, inline="always", fastmath=True)
def _sigmoid(x):  # pragma: no cover - compiled
    """The logistic function."""
    return _ONE / (_ONE + _exp(-x))


@numba.njit(cache=True, inline="always", fastmath=True)
def _tanh(x):  # pragma: no cover - compiled
    """``tanh(x) = 2 sigmoid(2x) - 1``."""
    return _TWO * _sigmoid(_TWO * x) - _ONE


@numba.njit(cache=True, nogil=True, fastmath=True)
def blstm_chunk(pre_f, pre_b, w_rec, peep, h, c, out, lo):  # pragma: no cover - compiled
    """Advance every network's forward and backward chain over one chunk of steps, in place.

    ``N`` networks give ``2N`` chains: forward chains ``0..N-1``, then backward ones. The chunk is
    steps ``lo .. lo+L-1`` for the forward chains and ``T-lo-L .. T-lo-1`` for the backward ones
    (``T = out.shape[1]``), which run from its end. ``pre_f`` and ``pre_b (N, L, 4H)`` hold those
    steps' input projections with bias in time order, gates ordered i, f, c, o; ``w_rec (2N, H, 4H)``;
    ``peep (2N, 3, H)`` for gates i, f, o; the state ``h`` and ``c (2N, H)`` is carried on to the
    next chunk. Outputs go to ``out (N, T, 2H)`` (forward | backward), as madmom's BLSTM layer.
    Gates i and f see the previous cell state, gate o the new one. ``fastmath`` only reorders
    float32 sums and products of finite values; results stay within about 1e-5 of madmom's.
    """
    n_nets, length, four_h = pre_f.shape
    hidden = four_h // 4
    steps = out.shape[1]
    for ch in range(2 * n_nets):
        net, back = ch % n_nets, ch >= n_nets
        w, p_i, p_f, p_o = w_rec[ch], peep[ch, 0], peep[ch, 1], peep[ch, 2]
        hc, cc = h[ch], c[ch]
        gates = np.empty(four_h, dtype=np.float32)
        cn = np.empty(hidden, dtype=np.float32)
        col = hidden if back else 0
        for s in range(length):
            if back:
                src, t = pre_b[net, length - 1 - s], steps - lo - 1 - s
            else:
                src, t = pre_f[net, s], lo + s
            for k in range(four_h):
                gates[k] = src[k]
            for j in range(hidden):
                hj = hc[j]
                for k in range(four_h):
                    gates[k] += hj * w[j, k]
            for j in range(hidden):  # two passes over j, so each vectorises
                cj = cc[j]
                gi = _sigmoid(gates[j] + cj * p_i[j])
                gf = _sigmoid(gates[hidden + j] + cj * p_f[j])
                cn[j] = cj * gf + _tanh(gates[2 * hidden + j]) * gi
            for j in range(hidden):
                go = _sigmoid(gates[3 * hidden + j] + cn[j] * p_o[j])
                cc[j] = cn[j]
                hc[j] = _tanh(cn[j]) * go
                out[net, t, col + j] = hc[j]
