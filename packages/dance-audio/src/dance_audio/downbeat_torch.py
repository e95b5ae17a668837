"""A torch port of madmom's RNNDownBeatProcessor: the same 8 BLSTM networks, run as one batch.

The ensemble's 8 networks x 2 directions become a batch of 16 independent peephole-LSTM chains
with their own weights (batched matrix products), so each time step is a handful of tensor ops
for the whole ensemble instead of madmom's 48 NumPy loops. The output is madmom's: the mean of
the networks' softmax outputs without the "no beat" column, i.e. (beat, downbeat) at 100 fps.
"""

from __future__ import annotations

import threading
import warnings

import numpy as np
import torch

from .downbeat_features import FPS, RATE, downbeat_input
from .madmom_weights import NetworkWeights, load_downbeat_ensemble

_lock = threading.Lock()
_model: DownbeatEnsemble | None = None
_scripted = None


class DownbeatEnsemble(torch.nn.Module):
    """The BLSTM ensemble; ``forward`` maps ``(T, 314)`` features to ``(T, 2)`` activations."""

    def __init__(self, nets: list[NetworkWeights]):
        super().__init__()
        self.n_nets = len(nets)
        for k in range(len(nets[0].layers)):
            dirs = [d for net in nets for d in net.layers[k]]  # net0 fwd, net0 bwd, net1 fwd, ...
            self.register_buffer(f"w_in{k}", torch.from_numpy(np.stack([d.w_in for d in dirs])))
            self.register_buffer(f"w_rec{k}", torch.from_numpy(np.stack([d.w_rec for d in dirs])))
            self.register_buffer(f"bias{k}", torch.from_numpy(np.stack([d.bias for d in dirs]))[:, None, :])
            self.register_buffer(f"peep{k}", torch.from_numpy(np.stack([d.peep for d in dirs])))
        self.n_layers = len(nets[0].layers)
        self.register_buffer("out_w", torch.from_numpy(np.stack([n.out_w for n in nets])))
        self.register_buffer("out_b", torch.from_numpy(np.stack([n.out_b for n in nets]))[:, None, :])

    def _layer(self, x: torch.Tensor, k: int) -> torch.Tensor:
        """One BLSTM layer for every chain: ``x`` is ``(2N, T, in)`` with backward chains time-reversed."""
        pre = torch.baddbmm(getattr(self, f"bias{k}"), x, getattr(self, f"w_in{k}"))  # (2N, T, 4H)
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # one step's tensors are tiny: threads only add synchronisation
        try:  # the plain TorchScript interpreter: no profiling runs, and faster on this tiny loop
            with torch.jit.optimized_execution(False):
                return _recurrence()(pre, getattr(self, f"w_rec{k}"), getattr(self, f"peep{k}"))
        finally:
            torch.set_num_threads(threads)

    @torch.no_grad()
    def forward(self, feats: torch.Tensor) -> torch.Tensor:
        """Ensemble-mean (beat, downbeat) probabilities, ``(T, 2)``."""
        n = self.n_nets
        x = feats.unsqueeze(0).expand(n, -1, -1)
        for k in range(self.n_layers):
            chains = torch.stack([x, x.flip(1)], dim=1).reshape(2 * n, x.shape[1], x.shape[2])
            y = self._layer(chains, k).reshape(n, 2, x.shape[1], -1)
            x = torch.cat([y[:, 0], y[:, 1].flip(1)], dim=2)  # (N, T, 2H): forward | backward
        probs = torch.softmax(torch.baddbmm(self.out_b, x, self.out_w), dim=2)
        return probs.mean(dim=0)[:, 1:]


def _peephole_lstm(pre: torch.Tensor, w_rec: torch.Tensor, peep: torch.Tensor) -> torch.Tensor:
    """Run peephole LSTM chains over time: gates i, f see the previous cell state, o the new one."""
    chains, steps = pre.shape[0], pre.shape[1]
    hidden = w_rec.shape[1]
    p_i, p_f, p_o = peep[:, 0], peep[:, 1], peep[:, 2]
    h = pre.new_zeros(chains, 1, hidden)
    c = pre.new_zeros(chains, hidden)
    out = pre.new_empty(chains, steps, hidden)
    for t in range(steps):
        g = torch.baddbmm(pre[:, t : t + 1], h, w_rec).squeeze(1)
        gi, gf, gc, go = g.chunk(4, dim=1)
        c = torch.addcmul(
            c * torch.sigmoid(torch.addcmul(gf, c, p_f)), torch.tanh(gc), torch.sigmoid(torch.addcmul(gi, c, p_i))
        )
        h_t = torch.tanh(c) * torch.sigmoid(torch.addcmul(go, c, p_o))
        out[:, t] = h_t
        h = h_t.unsqueeze(1)
    return out


def _recurrence():
    """The LSTM loop compiled with TorchScript once per process (Python per step would dominate)."""
    global _scripted
    if _scripted is None:
        with warnings.catch_warnings():  # TorchScript is deprecated in favour of torch.compile, which
            warnings.simplefilter("ignore", DeprecationWarning)  # needs a C compiler at run time
            _scripted = torch.jit.script(_peephole_lstm)
    return _scripted


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
