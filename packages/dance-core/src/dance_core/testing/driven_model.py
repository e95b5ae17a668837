"""A real ``ComposedModel`` around a head under test, so the kit drives the head through the loops' own code.

:class:`ProbeEncoder` stands where a recipe's encoder would, with its window and token count, and hands
out latents the kit chooses: one leaf tensor in training (so the check sees whether the loss reaches
it), seeded random ones when generating. :class:`CheckedHead` wraps the head at the contract's
boundary: each call the model makes to ``init_state``, ``step`` and ``finish`` is checked as it
happens (a step's frames, the state, the finished motion) and a failure names the call. Training
goes through ``ComposedModel.training_loss``, generation through ``ComposedModel.generate``, exactly
as ``dance train`` and ``dance compose`` call them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from torch import nn

from dance_core.model import ComposedModel
from dance_core.protocols import Window
from dance_core.testing.kit import Check


class ProbeEncoder(nn.Module):
    """An encoder with a given window, token count and width whose latent the kit chooses."""

    def __init__(self, window: Window, latent_tokens: int | None, out_dim: int):
        super().__init__()
        self.window, self.latent_tokens, self.out_dim = window, latent_tokens, out_dim
        #: training: the latent the next forward returns (a leaf tensor the check watches)
        self.latent: torch.Tensor | None = None
        #: generation: latents are drawn from this generator
        self.generator: torch.Generator | None = None

    def forward(self, motion: torch.Tensor | None, cond: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """The chosen latent, else a random one: ``(B, latent_tokens, d)`` windowed, ``(B, T, d)`` song-level."""
        if self.latent is not None:
            return self.latent
        stream = next(iter(cond.values()))
        batch = motion.shape[0] if motion is not None else stream.shape[0]
        length = stream.shape[1] if self.window.song_level else self.latent_tokens
        return torch.randn(batch, length, self.out_dim, generator=self.generator)


class CheckedHead(nn.Module):
    """The head under test, its generation calls checked as the model makes them."""

    def __init__(self, head: nn.Module, check: Check, motion_dim: int):
        super().__init__()
        self.inner, self.check, self.motion_dim = head, check, motion_dim
        self.frames, self.keep = head.frames, head.keep
        self.history_frames, self.latent_tokens = head.history_frames, head.latent_tokens
        #: steps taken since the last ``init_state`` (named in failures)
        self.steps = 0

    def loss(self, latent: torch.Tensor, target: torch.Tensor, history: torch.Tensor, ctx: Any) -> Any:
        """The head's losses (checked by the caller, which knows whether it trains or validates)."""
        return self.inner.loss(latent, target, history, ctx)

    def init_state(self, batch: int, generator: Any, song: Any = None) -> Any:
        """The head's state; behind a song-level encoder it sees the whole song, as in ``dance compose``."""
        self.steps = 0
        with self.check.calling("init_state"):
            if song is None:
                return self.inner.init_state(batch, generator)
            return self.inner.init_state(batch, generator, song=song)

    def step(self, latent: torch.Tensor, history: torch.Tensor, state: Any, temperature: float, generator: Any):
        """One generation step, its result checked: ``(frames, state)`` with ``(B, frames, D)`` finite frames."""
        i = self.steps
        self.steps += 1
        with self.check.calling(f"step {i}"):
            result = self.inner.step(latent, history, state, temperature, generator)
        self.check.that(
            isinstance(result, tuple) and len(result) == 2,
            f"step must return (frames, state), got {type(result).__name__}",
        )
        frames, state = result
        expected = (latent.shape[0], self.frames, self.motion_dim)
        self.check.tensor(frames, f"frames of step {i} (temperature {temperature})", expected)
        return frames, state

    def finish(self, motion: torch.Tensor, state: Any) -> torch.Tensor:
        """The head's finished motion, which must keep the motion's shape."""
        with self.check.calling("finish"):
            done = self.inner.finish(motion, state)
        self.check.tensor(done, "the motion returned by finish", tuple(motion.shape))
        return done


def driven_model(head: nn.Module, check: Check, window: Window, tokens: int | None, latent_dim: int,
                 motion_dim: int) -> tuple[ComposedModel, ProbeEncoder]:
    """A ``ComposedModel`` (no conditioners) chaining a probe encoder and the checked head; and the probe."""
    probe = ProbeEncoder(window, tokens, latent_dim)
    return ComposedModel({}, probe, CheckedHead(head, check, motion_dim)), probe
