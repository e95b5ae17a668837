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

    def _projection(self, x: torch.Tensor, k: int, lo: int, hi: int) -> torch.Tensor:
        """Input projections of steps ``lo:hi`` of every chain, ``(2N, hi - lo, 4H)``; ``x`` is ``(N, T, in)``."""
        steps = x.shape[1]
        fwd = torch.baddbmm(getattr(self, f"bias_f{k}"), x[:, lo:hi], getattr(self, f"w_in_f{k}"))
        back = x[:, steps - hi : steps - lo].flip(1)  # backward chains read the song from its end
        bwd = torch.baddbmm(getattr(self, f"bias_b{k}"), back, getattr(self, f"w_in_b{k}"))
        return torch.cat([fwd, bwd], dim=0)

    def _layer(self, x: torch.Tensor, k: int) -> torch.Tensor:
        """One BLSTM layer of every network: ``(N, T, in)`` to ``(N, T, 2H)`` (forward | backward)."""
        n, steps = self.n_nets, x.shape[1]
        w_rec, peep = getattr(self, f"w_rec{k}"), getattr(self, f"peep{k}")
        hidden = w_rec.shape[1]
        h = x.new_zeros(2 * n, 1, hidden)
        c = x.new_zeros(2 * n, 1, hidden)
        outs = []
        for lo in range(0, steps, CHUNK):
            pre = self._projection(x, k, lo, min(lo + CHUNK, steps))
            threads = torch.get_num_threads()
            torch.set_num_threads(1)  # one step's tensors are tiny: threads only add synchronisation
            try:  # the plain TorchScript interpreter: no profiling runs, and faster on this tiny loop
                with torch.jit.optimized_execution(False):
                    out, h, c = _recurrence()(pre, w_rec, peep, h, c)
            finally:
                torch.set_num_threads(threads)
            outs.append(out)
        y = torch.cat(outs, dim=1)  # (2N, T, H), backward chains in reversed time
        return torch.cat([y[:n], y[n:].flip(1)], dim=2)

    @torch.no_grad()
    def forward(self, feats: torch.Tensor) -> torch.Tensor:
        """Ensemble-mean (beat, downbeat) probabilities, ``(T, 2)``."""
        x = feats.unsqueeze(0).expand(self.n_nets, -1, -1)
        for k in range(self.n_layers):
            x = self._layer(x, k)
        probs = torch.softmax(torch.baddbmm(self.out_b, x, self.out_w), dim=2)
        return probs.mean(dim=0)[:, 1:]


def _peephole_lstm(
    pre: torch.Tensor, w_rec: torch.Tensor, peep: torch.Tensor, h: torch.Tensor, c: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Run peephole LSTM chains over ``pre``'s steps from state ``(h, c)``; returns outputs and the end state.

    Shapes: ``pre (chains, steps, 4H)``, ``h`` and ``c (chains, 1, H)``, ``peep (chains, 3, H)``.
    Gates i and f see the previous cell state, gate o the new one (madmom's LSTMLayer). Everything
    stays 3-D so a step is only the gate arithmetic (no reshapes or indexed writes).
    """
    p_i, p_f, p_o = peep[:, 0:1], peep[:, 1:2], peep[:, 2:3]
    outs: list[torch.Tensor] = []
    for t in range(pre.shape[1]):
        gi, gf, gc, go = torch.baddbmm(pre[:, t : t + 1], h, w_rec).chunk(4, dim=2)
        c = torch.addcmul(
            c * torch.sigmoid(torch.addcmul(gf, c, p_f)), torch.tanh(gc), torch.sigmoid(torch.addcmul(gi, c, p_i))
        )
        h = torch.tanh(c) * torch.sigmoid(torch.addcmul(go, c, p_o))
        outs.append(h)
    return torch.cat(outs, dim=1), h, c


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
