"""A torch port of madmom's RNNDownBeatProcessor: the same 8 BLSTM networks, run as one batch.

The ensemble's 8 networks x 2 directions become 16 independent peephole-LSTM chains: torch computes
each layer's input projections for all of them (batched matrix products), and a compiled numba
kernel (``lstm_kernel``) runs the strictly sequential recurrence, instead of madmom's 48 NumPy
loops of tiny per-step products. The output is madmom's: the mean of
the networks' softmax outputs without the "no beat" column, i.e. (beat, downbeat) at 100 fps.
"""

from __future__ import annotations

import threading

import numpy as np
import torch

from .downbeat_features import FPS, RATE, downbeat_input
from .lstm_kernel import blstm_chunk
from .madmom_weights import NetworkWeights, load_downbeat_ensemble

_lock = threading.Lock()
_model: DownbeatEnsemble | None = None
CHUNK = 2048  # steps whose input projections are computed at once


class DownbeatEnsemble(torch.nn.Module):
    """The BLSTM ensemble; ``forward`` maps ``(T, 314)`` features to ``(T, 2)`` activations.

    Chains are ordered forward chains of networks 0..N-1, then their backward chains. Input
    projections are computed ``CHUNK`` steps at a time, so a 20-minute song needs no
    ``(16, T, 314)`` copy of its input.
    """

    def __init__(self, nets: list[NetworkWeights]):
        super().__init__()
        self.n_nets = len(nets)
        self.n_layers = len(nets[0].layers)

        def stack(arrays):
            return torch.from_numpy(np.stack(arrays))

        for k in range(self.n_layers):
            fwd = [net.layers[k][0] for net in nets]
            bwd = [net.layers[k][1] for net in nets]
            self.register_buffer(f"w_in_f{k}", stack([d.w_in for d in fwd]))
            self.register_buffer(f"w_in_b{k}", stack([d.w_in for d in bwd]))
            self.register_buffer(f"bias_f{k}", stack([d.bias for d in fwd])[:, None, :])
            self.register_buffer(f"bias_b{k}", stack([d.bias for d in bwd])[:, None, :])
            self.register_buffer(f"w_rec{k}", stack([d.w_rec for d in fwd + bwd]))
            self.register_buffer(f"peep{k}", stack([d.peep for d in fwd + bwd]))
        self.register_buffer("out_w", stack([n.out_w for n in nets]))
        self.register_buffer("out_b", stack([n.out_b for n in nets])[:, None, :])

    def _projections(self, x: torch.Tensor, k: int, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
        """Input projections with bias, ``(N, hi - lo, 4H)`` each, in time order: the forward chains'
        for steps ``lo:hi``, the backward chains' for steps ``T-hi:T-lo`` (they read the song from its end)."""
        steps = x.shape[1]
        fwd = torch.baddbmm(getattr(self, f"bias_f{k}"), x[:, lo:hi], getattr(self, f"w_in_f{k}"))
        bwd = torch.baddbmm(getattr(self, f"bias_b{k}"), x[:, steps - hi : steps - lo], getattr(self, f"w_in_b{k}"))
        return fwd.numpy(), bwd.numpy()

    def _layer(self, x: torch.Tensor, k: int) -> torch.Tensor:
        """One BLSTM layer of every network: ``(N, T, in)`` to ``(N, T, 2H)`` (forward | backward)."""
        n, steps = self.n_nets, x.shape[1]
        w_rec, peep = getattr(self, f"w_rec{k}").numpy(), getattr(self, f"peep{k}").numpy()
        hidden = w_rec.shape[1]
        h = np.zeros((2 * n, hidden), dtype=np.float32)
        c = np.zeros((2 * n, hidden), dtype=np.float32)
        out = np.empty((n, steps, 2 * hidden), dtype=np.float32)
        for lo in range(0, steps, CHUNK):
            pre_f, pre_b = self._projections(x, k, lo, min(lo + CHUNK, steps))
            blstm_chunk(pre_f, pre_b, w_rec, peep, h, c, out, lo)  # carries (h, c) on to the next chunk
        return torch.from_numpy(out)

    @torch.no_grad()
    def forward(self, feats: torch.Tensor) -> torch.Tensor:
        """Ensemble-mean (beat, downbeat) probabilities, ``(T, 2)``."""
        x = feats.unsqueeze(0).expand(self.n_nets, -1, -1)
        for k in range(self.n_layers):
            x = self._layer(x, k)
        probs = torch.softmax(torch.baddbmm(self.out_b, x, self.out_w), dim=2)
        return probs.mean(dim=0)[:, 1:]


def ensemble() -> DownbeatEnsemble:
    """The ensemble built once per process from the installed madmom package's weights."""
    global _model
    with _lock:
        if _model is None:
            _model = DownbeatEnsemble(load_downbeat_ensemble()).eval()
        return _model


def downbeat_activations(samples_44k: np.ndarray) -> np.ndarray:
    """``(ceil(len / 441), 2)`` float32 beat and downbeat activations at 100 fps for 44.1 kHz mono."""
    feats = torch.from_numpy(downbeat_input(samples_44k))
    if len(feats) == 0:
        return np.zeros((0, 2), dtype=np.float32)
    return ensemble()(feats).numpy().astype(np.float32)


__all__ = ["FPS", "RATE", "DownbeatEnsemble", "downbeat_activations", "ensemble"]
