"""Vector quantization with a straight-through gradient (van den Oord et al., 2017), as TM2D's tokenizer.

Each latent vector is replaced by its nearest code (Euclidean); the decoder's gradient passes to the
encoder unchanged (straight-through). The codebook loss ``||sg[z] - e||²`` moves the chosen codes toward
the encoder's outputs, the commitment loss ``β ||z - sg[e]||²`` keeps the outputs near their codes.

Dead-code restart (an option, off in TM2D): a code no batch has chosen for ``restart_after`` training
batches is replaced by a randomly drawn encoder output of the current batch, before that batch is
quantized (so no tensor the backward pass needs is changed in place).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn


@dataclass
class Quantized:
    """What quantizing a batch gives: straight-through codes, their indices and the losses and statistics."""

    codes: torch.Tensor
    indices: torch.Tensor
    codebook_loss: torch.Tensor
    commitment_loss: torch.Tensor
    usage: torch.Tensor
    perplexity: torch.Tensor


def code_statistics(indices: torch.Tensor, codes: int) -> tuple[torch.Tensor, torch.Tensor]:
    """(fraction of the codebook used, perplexity ``exp(entropy)`` of the code histogram) of ``indices``."""
    counts = torch.bincount(indices.flatten(), minlength=codes).float()
    p = counts / counts.sum().clamp_min(1.0)
    entropy = -(p * torch.log(p.clamp_min(1e-12))).sum()
    return (counts > 0).float().mean(), entropy.exp()


class VectorQuantizer(nn.Module):
    """A codebook of ``codes`` vectors of ``dim`` channels; ``forward`` quantizes ``(..., dim)``."""

    def __init__(self, codes: int, dim: int, beta: float = 0.25, restart_after: int | None = None):
        super().__init__()
        self.codes, self.dim, self.beta, self.restart_after = codes, dim, beta, restart_after
        self.codebook = nn.Parameter(torch.empty(codes, dim).uniform_(-1.0 / codes, 1.0 / codes))
        if restart_after is not None:
            self.register_buffer("idle", torch.zeros(codes, dtype=torch.long))

    def nearest(self, z: torch.Tensor) -> torch.Tensor:
        """Index of the nearest code of every vector in ``(..., dim)``, shape ``(...)``."""
        flat = z.reshape(-1, self.dim)
        e = self.codebook
        distance = flat.square().sum(1, keepdim=True) - 2 * flat @ e.t() + e.square().sum(1)[None]
        return distance.argmin(1).view(z.shape[:-1])

    def lookup(self, indices: torch.Tensor) -> torch.Tensor:
        """The codes of ``indices``: ``(...) -> (..., dim)``."""
        return F.embedding(indices, self.codebook)

    @torch.no_grad()
    def restart_dead(self, z: torch.Tensor, generator: torch.Generator | None = None) -> int:
        """Replace codes idle for ``restart_after`` batches by random rows of ``z`` ``(..., dim)``; how many."""
        dead = (self.idle >= self.restart_after).nonzero().flatten()
        if len(dead) == 0:
            return 0
        flat = z.detach().reshape(-1, self.dim)
        gen_device = generator.device if generator is not None else None
        picks = torch.randint(len(flat), (len(dead),), generator=generator, device=gen_device).to(flat.device)
        self.codebook.data[dead] = flat[picks].to(self.codebook.dtype)
        self.idle[dead] = 0
        return len(dead)

    def forward(self, z: torch.Tensor, generator: torch.Generator | None = None) -> Quantized:
        """Quantize ``z (..., dim)``; restarts dead codes first when training with ``restart_after`` set."""
        if self.restart_after is not None and self.training and torch.is_grad_enabled():
            self.restart_dead(z, generator)
        indices = self.nearest(z.detach())
        chosen = self.lookup(indices)
        codebook_loss = F.mse_loss(chosen, z.detach())
        commitment_loss = F.mse_loss(z, chosen.detach())
        usage, perplexity = code_statistics(indices, self.codes)
        if self.restart_after is not None and self.training and torch.is_grad_enabled():
            used = torch.zeros(self.codes, dtype=torch.bool, device=indices.device)
            used[indices.flatten()] = True
            self.idle.add_(1).masked_fill_(used, 0)
        codes = z + (chosen - z).detach()  # straight-through: forward the code, backward the identity
        return Quantized(codes, indices, codebook_loss, commitment_loss, usage, perplexity)

    def loss(self, q: Quantized) -> torch.Tensor:
        """Codebook + β · commitment."""
        return q.codebook_loss + self.beta * q.commitment_loss
