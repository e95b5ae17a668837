"""A port of madmom's RNNDownBeatProcessor to NumPy and numba: the same 8 BLSTM networks, no torch.

Per network and BLSTM layer, the input projections of each direction are one BLAS matrix product
(NumPy) and the strictly sequential recurrence runs in a cached numba kernel
(``lstm_kernel.lstm_sequence``), instead of madmom's NumPy loops of tiny per-step products. The networks run
on two threads (the kernel releases the GIL), with BLAS held to one thread meanwhile
(:func:`.threads.one_blas_thread`). The output is
madmom's: the mean of the networks' softmax outputs without the "no beat" column, i.e.
(beat, downbeat) at 100 fps. Importing this module does not import torch, madmom or librosa.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .downbeat_features import FPS, RATE, downbeat_input
from .lstm_kernel import lstm_sequence
from .madmom_weights import LSTMWeights, load_downbeat_ensemble
from .threads import one_blas_thread

WORKERS = min(2, os.cpu_count() or 1)  # networks run side by side: the kernel releases the GIL
_lock = threading.Lock()
_layers: list[list[tuple[np.ndarray, np.ndarray, LSTMWeights, LSTMWeights]]] | None = None
_outputs: list[tuple[np.ndarray, np.ndarray]] | None = None


def networks() -> tuple[list, list]:
    """Per network, its BLSTM layers as ``(w_in, bias, fwd, bwd)`` with both directions' input
    weights side by side (one matrix product per layer), and its output layer ``(w, b)``; read
    once per process from the installed madmom package."""
    global _layers, _outputs
    with _lock:
        if _layers is None:
            nets = load_downbeat_ensemble()
            _layers = [
                [
                    (np.concatenate([f.w_in, b.w_in], axis=1), np.concatenate([f.bias, b.bias]), f, b)
                    for f, b in net.layers
                ]
                for net in nets
            ]
            _outputs = [(net.out_w, net.out_b) for net in nets]
        return _layers, _outputs


def _probabilities(feats: np.ndarray, layers: list, output: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """One network's softmax output ``(T, 3)``: no beat, beat, downbeat."""
    x = feats
    for w_in, bias, fwd, bwd in layers:
        hidden = fwd.w_rec.shape[0]
        pre = x @ w_in + bias  # (T, 8H): forward gates | backward gates
        x = np.empty((len(feats), 2 * hidden), dtype=np.float32)
        lstm_sequence(pre[:, : 4 * hidden], fwd.w_rec, fwd.peep, False, x[:, :hidden])
        lstm_sequence(pre[:, 4 * hidden :], bwd.w_rec, bwd.peep, True, x[:, hidden:])
    logits = x @ output[0] + output[1]
    logits -= logits.max(axis=1, keepdims=True)
    e = np.exp(logits)
    return e / e.sum(axis=1, keepdims=True)


def downbeat_activations(samples_44k: np.ndarray) -> np.ndarray:
    """``(ceil(len / 441), 2)`` float32 beat and downbeat activations at 100 fps for 44.1 kHz mono."""
    layers, outputs = networks()
    with one_blas_thread():
        feats = downbeat_input(samples_44k)
        if len(feats) == 0:
            return np.zeros((0, 2), dtype=np.float32)
        with ThreadPoolExecutor(WORKERS) as pool:
            probs = list(pool.map(_probabilities, [feats] * len(layers), layers, outputs))
    total = probs[0].copy()
    for p in probs[1:]:  # in network order, whatever thread finished first
        total += p
    return (total[:, 1:] / len(layers)).astype(np.float32)


__all__ = ["FPS", "RATE", "downbeat_activations", "networks"]
