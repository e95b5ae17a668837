"""A port of madmom's RNNDownBeatProcessor to NumPy and numba: the same 8 BLSTM networks, no torch.

Per network and BLSTM layer, the input projections of each direction are one BLAS matrix product
(NumPy) and the strictly sequential recurrence runs in a cached numba kernel
(``lstm_kernel.lstm_sequence``), instead of madmom's NumPy loops of tiny per-step products. No
threads of its own: BLAS already uses the cores for the products, and on a 2-core machine a
second thread of ours only fights OpenBLAS's spinning workers. The output is
madmom's: the mean of the networks' softmax outputs without the "no beat" column, i.e.
(beat, downbeat) at 100 fps. Importing this module does not import torch, madmom or librosa.
"""

from __future__ import annotations

import threading

import numpy as np

from .downbeat_features import FPS, RATE, downbeat_input
from .lstm_kernel import lstm_sequence
from .madmom_weights import LSTMWeights, NetworkWeights, load_downbeat_ensemble

_lock = threading.Lock()
_networks: list[NetworkWeights] | None = None


def networks() -> list[NetworkWeights]:
    """The ensemble's weights, read once per process from the installed madmom package."""
    global _networks
    with _lock:
        if _networks is None:
            _networks = load_downbeat_ensemble()
        return _networks


def _blstm(x: np.ndarray, fwd: LSTMWeights, bwd: LSTMWeights) -> np.ndarray:
    """One BLSTM layer: ``(T, in)`` to ``(T, 2H)`` (forward states | backward states)."""
    hidden = fwd.w_rec.shape[0]
    out = np.empty((len(x), 2 * hidden), dtype=np.float32)
    lstm_sequence(x @ fwd.w_in + fwd.bias, fwd.w_rec, fwd.peep, False, out[:, :hidden])
    lstm_sequence(x @ bwd.w_in + bwd.bias, bwd.w_rec, bwd.peep, True, out[:, hidden:])
    return out


def _probabilities(feats: np.ndarray, net: NetworkWeights) -> np.ndarray:
    """One network's softmax output ``(T, 3)``: no beat, beat, downbeat."""
    x = feats
    for fwd, bwd in net.layers:
        x = _blstm(x, fwd, bwd)
    logits = x @ net.out_w + net.out_b
    logits -= logits.max(axis=1, keepdims=True)
    e = np.exp(logits)
    return e / e.sum(axis=1, keepdims=True)


def downbeat_activations(samples_44k: np.ndarray) -> np.ndarray:
    """``(ceil(len / 441), 2)`` float32 beat and downbeat activations at 100 fps for 44.1 kHz mono."""
    feats = downbeat_input(samples_44k)
    if len(feats) == 0:
        return np.zeros((0, 2), dtype=np.float32)
    nets = networks()
    total = np.zeros((len(feats), 3), dtype=np.float32)
    for net in nets:
        total += _probabilities(feats, net)
    return (total[:, 1:] / len(nets)).astype(np.float32)


__all__ = ["FPS", "RATE", "downbeat_activations", "networks"]
