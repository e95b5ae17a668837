"""TM2D's 3D human motion VQ-VAE: motion ``(B, T, D)`` to tokens ``(B, T / t)`` and back.

The encoder has ``log2(t)`` layers (3 for t = 8), each a stride-2 convolution followed by a residual
block; the decoder mirrors it with nearest-neighbour ×2 upsampling and a convolution per layer. All
convolutions are zero-padded "same" convolutions, so a decoded frame depends on a bounded window of
tokens: :meth:`MotionVQVAE.token_reach` gives it exactly (generation uses it to decode only the last
tokens, and the tests to know which frames a changed token can reach).
"""

from __future__ import annotations

import math
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from dance_tokens.positions import position_losses
from dance_tokens.quantizer import Quantized, VectorQuantizer


class ResBlock(nn.Module):
    """``x + conv1x1(relu(conv3(relu(x))))`` over ``(B, C, T)``."""

    def __init__(self, width: int):
        super().__init__()
        self.convs = nn.Sequential(nn.ReLU(), nn.Conv1d(width, width, 3, padding=1), nn.ReLU(),
                                   nn.Conv1d(width, width, 1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Residual update, same shape."""
        return x + self.convs(x)


def _reach(modules: list[nn.Module], lo: int, hi: int) -> tuple[int, int]:
    """Input positions ``[lo', hi']`` that outputs ``[lo, hi]`` of ``modules`` (applied in order) depend on,
    for stride-1 convolutions, nearest upsampling, residual blocks and pointwise layers."""
    for module in reversed(modules):
        if isinstance(module, nn.Conv1d):
            (k,), (p,), (d,) = module.kernel_size, module.padding, module.dilation
            lo, hi = lo - p, hi - p + d * (k - 1)
        elif isinstance(module, nn.Upsample):
            lo, hi = lo // int(module.scale_factor), hi // int(module.scale_factor)
        elif isinstance(module, ResBlock):
            lo, hi = _reach(list(module.convs), lo, hi)  # the identity path lies inside this window
        elif isinstance(module, nn.Sequential):
            lo, hi = _reach(list(module), lo, hi)
    return lo, hi


class MotionVQVAE(nn.Module):
    """Conv encoder, :class:`~dance_tokens.quantizer.VectorQuantizer`, conv decoder."""

    def __init__(self, motion_dim: int, config):
        super().__init__()
        c = config
        self.downsample, self.recon = c.downsample, c.recon
        self.velocity, self.acceleration = c.velocity, c.acceleration
        self.positions, self.position_velocity = c.positions, c.position_velocity
        self.position_weights = dict(c.position_weights)
        weights = torch.ones(motion_dim)
        weights[: c.root_channels] = c.root_weight
        self.register_buffer("channel_weights", weights, persistent=False)
        w = c.width
        layers = int(math.log2(c.downsample))
        enc: list[nn.Module] = [nn.Conv1d(motion_dim, w, 3, padding=1)]
        for _ in range(layers):
            enc += [nn.ReLU(), nn.Conv1d(w, w, 4, stride=2, padding=1), ResBlock(w)]
        enc += [nn.ReLU(), nn.Conv1d(w, c.code_dim, 3, padding=1)]
        self.encoder = nn.Sequential(*enc)
        self.quantizer = VectorQuantizer(c.codes, c.code_dim, c.beta, c.restart_after)
        dec: list[nn.Module] = [nn.Conv1d(c.code_dim, w, 3, padding=1)]
        for _ in range(layers):
            dec += [ResBlock(w), nn.Upsample(scale_factor=2, mode="nearest"), nn.Conv1d(w, w, 3, padding=1), nn.ReLU()]
        dec += [nn.Conv1d(w, motion_dim, 3, padding=1)]
        self.decoder = nn.Sequential(*dec)

    def encode_latent(self, motion: torch.Tensor) -> torch.Tensor:
        """Continuous latents ``(B, T / t, code_dim)`` of motion ``(B, T, D)`` (T a multiple of t)."""
        return self.encoder(motion.transpose(1, 2)).transpose(1, 2)

    def encode(self, motion: torch.Tensor) -> torch.Tensor:
        """Tokens ``(B, T / t)`` of motion ``(B, T, D)``; frames past the last whole token are dropped."""
        n = motion.shape[1] // self.downsample * self.downsample
        return self.quantizer.nearest(self.encode_latent(motion[:, :n]))

    def decode_codes(self, codes: torch.Tensor) -> torch.Tensor:
        """Motion ``(B, t·n, D)`` of code vectors ``(B, n, code_dim)``."""
        return self.decoder(codes.transpose(1, 2)).transpose(1, 2)

    def decode(self, tokens: torch.Tensor) -> torch.Tensor:
        """Motion ``(B, t·n, D)`` of tokens ``(B, n)``."""
        return self.decode_codes(self.quantizer.lookup(tokens))

    def forward(self, motion: torch.Tensor, generator: torch.Generator | None = None) -> tuple[torch.Tensor, Quantized]:
        """Reconstruction of ``motion (B, T, D)`` and the quantization (T a multiple of t)."""
        q = self.quantizer(self.encode_latent(motion), generator)
        return self.decode_codes(q.codes), q

    def loss(self, motion: torch.Tensor, generator: torch.Generator | None = None,
             kinematics: Any = None) -> dict[str, torch.Tensor]:
        """Reconstruction (L1, or smooth L1; the first ``root_channels`` weighed ``root_weight``) + codebook +
        β · commitment, plus the optional L1 losses on the first and second frame differences (``velocity``,
        ``acceleration`` weights) and on the joints' positions and their frame differences (``positions``,
        ``position_velocity``: ``kinematics`` maps motion to joint positions, see
        :mod:`dance_tokens.positions`), with the L1 error, codebook usage and perplexity."""
        recon, q = self(motion, generator)
        l1 = F.l1_loss(recon, motion)
        per = F.l1_loss(recon, motion, reduction="none") if self.recon == "l1" else \
            F.smooth_l1_loss(recon, motion, reduction="none")
        fit = (per * self.channel_weights).mean()
        out = {}
        for order, weight, name in ((1, self.velocity, "velocity"), (2, self.acceleration, "acceleration")):
            if weight > 0:
                err = F.l1_loss(torch.diff(recon, n=order, dim=1), torch.diff(motion, n=order, dim=1))
                fit = fit + weight * err
                out[name] = err.detach()
        if self.positions > 0 or self.position_velocity > 0:
            position, step = position_losses(recon, motion, kinematics, self.position_weights)
            fit = fit + self.positions * position + self.position_velocity * step
            out["positions"], out["position_velocity"] = position.detach(), step.detach()
        return {"loss": fit + self.quantizer.loss(q), "recon": l1.detach(), "commitment": q.commitment_loss.detach(),
                "usage": q.usage, "perplexity": q.perplexity, **out}

    def token_reach(self, frame: int) -> tuple[int, int]:
        """The tokens ``[first, last]`` decoded frame ``frame`` depends on (before clipping to the sequence)."""
        return _reach(list(self.decoder), frame, frame)

    def receptive_field(self) -> tuple[int, int]:
        """(past, future) tokens: the most tokens before and after its own that any decoded frame depends on."""
        t = self.downsample
        spans = [self.token_reach(f) for f in range(t)]
        return max(-lo for lo, _ in spans), max(hi for _, hi in spans)

    def first_frame_reached(self, token: int) -> int:
        """The first decoded frame that token ``token`` can change."""
        _, future = self.receptive_field()
        frame = max(0, (token - future - 1) * self.downsample)  # every earlier frame ends before the token
        while self.token_reach(frame)[1] < token:
            frame += 1
        return frame
