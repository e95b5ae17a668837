"""DanceRevolution's dance decoder: a stacked LSTM whose initial state is drawn from N(0, I).

Step ``i`` feeds the previous frame through a linear pose embedding into the LSTM and predicts
``ŷ_i = [h_i; z_i] W + b`` from the top hidden state ``h_i`` and the aligned music latent ``z_i``.
Training uses dynamic auto-condition (:mod:`dance_rnn.curriculum`): periods of ``p`` ground-truth
inputs then ``q`` of the decoder's own (detached) predictions, with ``q`` read from a named training
schedule; the loss is L1 over every frame. Generation carries the LSTM state across the whole song.

The layers are a standard stack (each layer reads the fresh output of the one below); the reference
code feeds layer ``k + 1`` the previous step's state of layer ``k`` instead.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from dance_core import RecipeError, TrainContext
from dance_rnn.curriculum import ground_truth_inputs

State = tuple[torch.Tensor, torch.Tensor]


class LSTMDecoder(nn.Module):
    """The ``lstm-decoder`` head: one frame per step, the previous frame as its history."""

    frames = 1
    keep = 1
    history_frames = 1
    latent_tokens = None

    def __init__(self, config, motion_dim: int, latent_dim: int):
        super().__init__()
        self.config = config
        pose_dim = config.pose_dim or motion_dim
        self.pose = nn.Linear(motion_dim, pose_dim)
        self.drop = nn.Dropout(config.dropout)
        self.lstm = nn.LSTM(
            pose_dim,
            config.hidden,
            config.layers,
            batch_first=True,
            dropout=config.dropout if config.layers > 1 else 0.0,
        )
        self.out = nn.Linear(config.hidden + latent_dim, motion_dim)

    def init_state(self, batch: int, generator: torch.Generator | None = None, song: Any = None) -> State:
        """``(h0, c0)``, each ``(layers, B, hidden)`` drawn from N(0, init_scale²)."""
        shape = (self.config.layers, batch, self.config.hidden)
        w = self.out.weight
        h = torch.randn(shape, generator=generator, device=w.device, dtype=w.dtype)
        c = torch.randn(shape, generator=generator, device=w.device, dtype=w.dtype)
        return h * self.config.init_scale, c * self.config.init_scale

    def run(self, inputs: torch.Tensor, latent: torch.Tensor, state: State) -> tuple[torch.Tensor, State]:
        """Frames ``(B, L, D)`` predicted from input frames ``(B, L, D)`` and latents ``(B, L, d)``."""
        x = self.drop(self.pose(inputs))
        hidden, state = self.lstm(x, state) if x.shape[1] > 1 else self._one_step(x, state)
        return self.out(torch.cat([hidden, latent.to(hidden.dtype)], dim=-1)), state

    def _one_step(self, x: torch.Tensor, state: State) -> tuple[torch.Tensor, State]:
        """One time step through the stack with the LSTM's own weights (the same function as
        ``self.lstm`` on a length-1 sequence, without its per-call overhead)."""
        h, c = state
        lstm, inp = self.lstm, x[:, 0]
        hs, cs = [], []
        for k in range(lstm.num_layers):
            if k:
                inp = F.dropout(inp, lstm.dropout, self.training)
            gates = F.linear(inp, getattr(lstm, f"weight_ih_l{k}"), getattr(lstm, f"bias_ih_l{k}"))
            gates = gates + F.linear(h[k], getattr(lstm, f"weight_hh_l{k}"), getattr(lstm, f"bias_hh_l{k}"))
            i, f, g, o = gates.chunk(4, dim=-1)  # PyTorch's gate order
            c_k = torch.sigmoid(f) * c[k] + torch.sigmoid(i) * torch.tanh(g)
            inp = torch.sigmoid(o) * torch.tanh(c_k)
            hs.append(inp)
            cs.append(c_k)
        return inp[:, None], (torch.stack(hs), torch.stack(cs))

    def rollout(
        self,
        latent: torch.Tensor,
        target: torch.Tensor,
        history: torch.Tensor,
        q: int,
        generator: torch.Generator | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Predictions ``(B, T, D)`` under auto-condition, and the inputs actually fed ``(B, T, D)``.

        Input ``i`` is the ground-truth frame before target ``i`` or, in the generated part of each
        period, the (detached) prediction of step ``i - 1``. Runs of ground-truth inputs go through
        the LSTM in one call; generated inputs one step at a time.
        """
        length = target.shape[1]
        truth = torch.cat([history[:, -1:], target[:, :-1]], dim=1)
        mask = ground_truth_inputs(length, self.config.teacher_frames, q)
        state = self.init_state(target.shape[0], generator)
        preds: list[torch.Tensor] = []
        inputs: list[torch.Tensor] = []
        i = 0
        while i < length:
            if mask[i]:
                j = i
                while j < length and mask[j]:
                    j += 1
                x = truth[:, i:j]
            else:
                j = i + 1
                x = preds[-1][:, -1:].detach()
            y, state = self.run(x, latent[:, i:j], state)
            preds.append(y)
            inputs.append(x)
            i = j
        return torch.cat(preds, dim=1), torch.cat(inputs, dim=1)

    def generated_per_period(self, ctx: TrainContext) -> int:
        """q at this point of training, from the schedule the config names (0 without one)."""
        name = self.config.auto_condition
        if name is None:
            return 0
        if name not in ctx.values:
            raise RecipeError(
                f"training.schedules.{name}: the lstm-decoder head reads q from this schedule; add one "
                f"(e.g. {{plugin: auto-condition-linear}}) or set model.head.auto_condition: null"
            )
        q = int(ctx.values[name])
        if q < 0:
            raise RecipeError(f"training.schedules.{name}: q must be >= 0, got {ctx.values[name]}")
        return q

    def loss(
        self, latent: torch.Tensor, target: torch.Tensor, history: torch.Tensor, ctx: TrainContext
    ) -> dict[str, torch.Tensor]:
        """L1 error of every predicted frame under the curriculum's current q."""
        pred, _ = self.rollout(latent, target, history, self.generated_per_period(ctx), ctx.generator)
        return {"loss": (pred - target).abs().mean()}

    def step(
        self,
        latent: torch.Tensor,
        history: torch.Tensor,
        state: State | None,
        temperature: float = 1.0,
        generator: torch.Generator | None = None,
    ) -> tuple[torch.Tensor, State]:
        """The next frame ``(B, 1, D)`` from the previous one; ``temperature`` has no effect (the
        randomness is all in the initial state)."""
        if state is None:
            state = self.init_state(history.shape[0], generator)
        return self.run(history[:, -1:], latent[:, :1], state)

    def finish(self, motion: torch.Tensor, state: Any) -> torch.Tensor:
        """Identity."""
        return motion


def build(config, *, motion_dim: int, latent_dim: int, window=None, **_: Any) -> LSTMDecoder:
    """Build the ``lstm-decoder`` head; it needs a song-level encoder (one latent per frame)."""
    if window is not None and not window.song_level:
        raise ValueError("needs a song-level encoder (one latent per frame), got a windowed one")
    return LSTMDecoder(config, motion_dim, latent_dim)
