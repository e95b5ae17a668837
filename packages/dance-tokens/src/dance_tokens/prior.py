"""TM2D's cross-modal token prior: a text encoder and one causal motion decoder shared by music and text.

The decoder reads ``[BOS, token_0, ..., token_{n-2}]`` and predicts ``token_0 .. token_{n-1}``; at input
position ``j`` it attends causally to the last ``context`` inputs and across either to the audio memory
(audio tokens within ``radius`` of ``j``, rotary positions) or to a sentence's text memory (its non-pad
words). The final hidden states come out before the projection to the ``K`` classes, so that generation
can mix the audio and text branches there (late fusion).
"""

from __future__ import annotations

import torch
from torch import nn

from dance_tokens.attention import band_mask, causal_mask
from dance_tokens.transformer import Decoder, Encoder


class TextEncoder(nn.Module):
    """Word-token ids ``(S, W)`` (0 is padding) to a text memory ``(S, W, dim)``: learned word
    embeddings and transformer encoder layers with rotary positions over the words."""

    def __init__(self, vocab_size: int, dim: int, layers: int, heads: int, ffn: int, dropout: float):
        super().__init__()
        self.vocab_size = vocab_size
        self.embed = nn.Embedding(vocab_size, dim, padding_idx=0)
        self.transformer = Encoder(layers, dim, heads, ffn, dropout)

    def forward(self, ids: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The memory and its key mask ``(S, 1, 1, W)`` (True at words, False at padding)."""
        mask = ids.ne(0)[:, None, None, :]
        positions = torch.arange(ids.shape[1], device=ids.device)
        return self.transformer(self.embed(ids), mask, positions), mask


class CrossModalPrior(nn.Module):
    """Token embedding (with BOS), audio-memory projection, text encoder, shared decoder, projection to K."""

    def __init__(self, config, codes: int, latent_dim: int, text: bool):
        super().__init__()
        c = config
        self.codes, self.context, self.radius = codes, c.context, c.radius
        self.bos = codes
        self.embed = nn.Embedding(codes + 1, c.dim)
        self.audio = nn.Identity() if latent_dim == c.dim else nn.Linear(latent_dim, c.dim)
        self.text = TextEncoder(c.vocab_size, c.dim, c.text_layers, c.heads, c.ffn, c.dropout) if text else None
        self.decoder = Decoder(c.layers, c.dim, c.heads, c.ffn, c.dropout)
        self.project = nn.Linear(c.dim, codes)

    def inputs(self, tokens: torch.Tensor) -> torch.Tensor:
        """Teacher-forced inputs ``[BOS, tokens[:-1]]`` of targets ``tokens (B, n)``."""
        bos = torch.full_like(tokens[:, :1], self.bos)
        return torch.cat([bos, tokens[:, :-1]], dim=1)

    def hidden_audio(
        self, inputs: torch.Tensor, positions: torch.Tensor, audio: torch.Tensor, audio_positions: torch.Tensor
    ) -> torch.Tensor:
        """Final hidden states ``(B, N, dim)`` of ``inputs (B, N)`` at ``positions`` over audio memory
        ``(B, M, dim)`` (projected) at ``audio_positions``."""
        self_mask = causal_mask(positions, positions, self.context)
        memory_mask = band_mask(positions, audio_positions, self.radius)
        return self.decoder(self.embed(inputs), audio, self_mask, memory_mask, positions, audio_positions)

    def hidden_text(
        self, inputs: torch.Tensor, positions: torch.Tensor, text: torch.Tensor, text_mask: torch.Tensor
    ) -> torch.Tensor:
        """Final hidden states ``(B, N, dim)`` of ``inputs (B, N)`` over text memory ``(B, W, dim)``."""
        self_mask = causal_mask(positions, positions, self.context)
        return self.decoder(self.embed(inputs), text, self_mask, text_mask, positions)

    def logits(self, hidden: torch.Tensor) -> torch.Tensor:
        """Scores of the ``K`` codes."""
        return self.project(hidden)
