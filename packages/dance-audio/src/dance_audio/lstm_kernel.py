"""A numba kernel for a bidirectional peephole-LSTM ensemble (madmom's LSTMLayer), compiled once and cached."""

from __future__ import annotations

import math

import numpy as np

from .numba_cache import use_cache_dir

use_cache_dir()  # before numba's first import, so the compiled kernel lands in dance's cache

import numba  # noqa: E402


@numba.njit(cache=True, nogil=True)
def blstm_chunk(pre_f, pre_b, w_rec, peep, h, c, out, lo):  # pragma: no cover - compiled
    """Advance every network's forward and backward chain over one chunk of steps, in place.

    ``N`` networks give ``2N`` chains: forward chains ``0..N-1``, then backward ones. The chunk is
    steps ``lo .. lo+L-1`` for the forward chains and ``T-lo-L .. T-lo-1`` for the backward ones
    (``T = out.shape[1]``), which run from its end. ``pre_f`` and ``pre_b (N, L, 4H)`` hold those
    steps' input projections with bias in time order, gates ordered i, f, c, o; ``w_rec (2N, H, 4H)``;
    ``peep (2N, 3, H)`` for gates i, f, o; the state ``h`` and ``c (2N, H)`` is carried on to the
    next chunk. Outputs go to ``out (N, T, 2H)`` (forward | backward), as madmom's BLSTM layer.
    Gates i and f see the previous cell state, gate o the new one.
    """
    n_nets, length, four_h = pre_f.shape
    hidden = four_h // 4
    steps = out.shape[1]
    for ch in range(2 * n_nets):
        net, back = ch % n_nets, ch >= n_nets
        w, p_i, p_f, p_o = w_rec[ch], peep[ch, 0], peep[ch, 1], peep[ch, 2]
        hc, cc = h[ch], c[ch]
        gates = np.empty(four_h, dtype=np.float32)
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
            for j in range(hidden):
                cj = cc[j]
                gi = 1.0 / (1.0 + math.exp(-(gates[j] + cj * p_i[j])))
                gf = 1.0 / (1.0 + math.exp(-(gates[hidden + j] + cj * p_f[j])))
                cn = cj * gf + math.tanh(gates[2 * hidden + j]) * gi
                go = 1.0 / (1.0 + math.exp(-(gates[3 * hidden + j] + cn * p_o[j])))
                cc[j] = cn
                hc[j] = math.tanh(cn) * go
                out[net, t, col + j] = hc[j]
