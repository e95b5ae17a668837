"""The ``tm2d`` output head: TM2D's motion VQ-VAE, text encoder and shared causal motion decoder.

A sequence head behind a song-level encoder (``tm2d-audio``): one step is one token, ``t`` frames.

- Training, stage ``tokenizer_stage``: the VQ-VAE on random ``crop``-frame crops of each segment.
  Any other stage: the frozen VQ-VAE tokenizes the segment, and the decoder is trained teacher-forced
  with cross-entropy; a sample in which a text span is in force takes the text branch
  (cross-attention to the sentence in force over most of its frames), the others the music branch
  (cross-attention to the audio memory, the encoder's latent at the token rate), both in one batch as
  the paper trains them.
- Generation: ``init_state`` takes the song's audio memory, reads the span in force at each token
  from the song's span table (``SongInputs.spans``), encodes each run's sentence (the text stream's
  row of that span: its word ids), and lays the fusion weights over the tokens; each ``step`` samples one token from
  ``h = w · h_text + (1 - w) · h_audio`` (final hidden states, before the projection), running the
  text branch only where ``w > 0``; ``finish`` decodes all the tokens jointly.

The text encoder lives in the head, not in an encoder or conditioner: its memory is a sentence's
words, not a per-frame stream, and a step needs the sentence of the span it is in.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from dance_core import RecipeError, SongInputs, TextSpans, TrainContext
from dance_tokens.fusion import fusion_weights, span_runs
from dance_tokens.prior import CrossModalPrior
from dance_tokens.rate import to_tokens, token_middles
from dance_tokens.sampling import sample_top_k
from dance_tokens.vqvae import MotionVQVAE


@dataclass
class TokenState:
    """Generation state: tokens so far, the audio memory, and the text spans' memories and weights.

    ``span_of (B, N)`` indexes ``text_memory`` per token (-1: no text), ``weight (B, N)`` is the fusion
    weight. Without a song (a head stepped on its own), ``audio`` grows by one token per step."""

    tokens: torch.Tensor
    audio: torch.Tensor | None
    grows: bool
    span_of: torch.Tensor | None = None
    weight: torch.Tensor | None = None
    text_memory: torch.Tensor | None = None
    text_mask: torch.Tensor | None = None


class TM2DHead(nn.Module):
    """``head.tokenizer.*`` (the VQ-VAE) and ``head.prior.*`` (text encoder, decoder): see the module."""

    history_frames = 0
    latent_tokens = None
    #: finish() decodes every token again, replacing the frames generated step by step: given frames
    #: (compose --from/--regenerate) cannot be continued from
    rewrites_motion = True

    def __init__(self, config, motion_dim: int, latent_dim: int):
        super().__init__()
        self.config = config
        self.frames = self.keep = self.t = config.tokenizer.downsample
        self.tokenizer = MotionVQVAE(motion_dim, config.tokenizer)
        self.prior = CrossModalPrior(config.prior, config.tokenizer.codes, latent_dim, config.text_stream is not None)

    # -- training

    def loss(
        self, latent: torch.Tensor, target: torch.Tensor, history: torch.Tensor, ctx: TrainContext
    ) -> dict[str, torch.Tensor]:
        """The VQ-VAE loss in the tokenizer stage, the decoder's cross-entropy in any other."""
        if ctx.stage == self.config.tokenizer_stage:
            return self.tokenizer.loss(self.crops(target, ctx.generator), ctx.generator, ctx.kinematics)
        return self.prior_loss(latent, target, ctx.spans)

    def crops(self, target: torch.Tensor, generator: torch.Generator | None) -> torch.Tensor:
        """A random ``tokenizer.crop``-frame crop of each segment ``(B, T, D)``."""
        crop = self.config.tokenizer.crop
        batch, length, _ = target.shape
        if length < crop:
            raise RecipeError(f"data.segment_frames ({length}) is shorter than model.head.tokenizer.crop ({crop})")
        device = generator.device if generator is not None else target.device
        starts = torch.randint(0, length - crop + 1, (batch,), generator=generator, device=device)
        frames = starts.to(target.device)[:, None] + torch.arange(crop, device=target.device)
        return target[torch.arange(batch, device=target.device)[:, None], frames]

    def prior_loss(
        self, latent: torch.Tensor, target: torch.Tensor, spans: TextSpans | None
    ) -> dict[str, torch.Tensor]:
        """Cross-entropy of the teacher-forced decoder on the frozen VQ-VAE's tokens of ``target``."""
        n = target.shape[1] // self.t
        if n == 0:
            raise RecipeError(f"data.segment_frames ({target.shape[1]}) is shorter than a token ({self.t} frames)")
        with torch.no_grad():
            tokens = self.tokenizer.encode(target[:, : n * self.t])
        sentences, has_text = self.sentences(spans, target.shape[0], target.device)
        inputs = self.prior.inputs(tokens)
        positions = torch.arange(n, device=target.device)
        music = ~has_text
        branches = []
        if music.any():
            audio = self.prior.audio(to_tokens(latent[music], self.t)[:, :n])
            hidden = self.prior.hidden_audio(inputs[music], positions, audio, positions)
            branches.append((music, self.prior.logits(hidden)))
        if has_text.any():
            memory, mask = self.prior.text(sentences[has_text])
            hidden = self.prior.hidden_text(inputs[has_text], positions, memory, mask)
            branches.append((has_text, self.prior.logits(hidden)))
        logits = branches[0][1].new_empty(target.shape[0], n, self.config.tokenizer.codes)
        for rows, values in branches:
            logits[rows] = values
        ce = F.cross_entropy(logits.flatten(0, 1), tokens.flatten(), reduction="none").view_as(tokens)
        out = {"loss": ce.mean(), "accuracy": (logits.argmax(-1) == tokens).float().mean()}
        if music.any():
            out["ce_music"] = ce[music].mean().detach()
        if has_text.any():
            out["ce_text"] = ce[has_text].mean().detach()
        return out

    def text_table(self, spans: TextSpans | None, strict: bool = True) -> tuple[torch.Tensor, torch.Tensor] | None:
        """The span in force per frame ``(B, T)`` and each span's word ids ``(S, W)`` from the text stream's
        rows of ``spans``, or None (music only, or no spans given). A text stream without rows (not made of
        text extractors) is a recipe error when ``strict`` (training), else music only."""
        name = self.config.text_stream
        if name is None or spans is None or (name not in spans.features and not strict):
            return None
        if name not in spans.features:
            raise RecipeError(f"model.head.text_stream: {name!r} is not a text stream (text streams: "
                              f"{', '.join(spans.features) or 'none'}): its extractors must all give rows per "
                              "text span, such as word-tokens; set it to null for music only")
        ids = spans.features[name].round().long()
        if ids.numel() and int(ids.max()) >= self.config.prior.vocab_size:
            raise RecipeError(f"model.head.prior.vocab_size ({self.config.prior.vocab_size}) is too small for "
                              f"word id {int(ids.max())}: set it to at least the vocabulary's length")
        return spans.index, ids

    def sentences(
        self, spans: TextSpans | None, batch: int, device: torch.device
    ) -> tuple[torch.Tensor | None, torch.Tensor]:
        """Per sample, the sentence (id row) in force over most of its frames (its spans' frames added up
        per sentence; the smallest id row of a tie), and whether a span is in force anywhere in it."""
        table = self.text_table(spans)
        has = torch.zeros(batch, dtype=torch.bool, device=device)
        if table is None:
            return None, has
        index, ids = table
        chosen = torch.zeros(batch, ids.shape[-1], dtype=torch.long, device=device)
        for b in range(batch):
            present = index[b][index[b] >= 0]
            if len(present):
                which, frames = torch.unique(present, return_counts=True)
                rows, sentence = torch.unique(ids[which], dim=0, return_inverse=True)
                per_sentence = torch.zeros(len(rows), dtype=frames.dtype, device=frames.device)
                per_sentence.index_add_(0, sentence, frames)
                chosen[b], has[b] = rows[per_sentence.argmax()], True
        return chosen, has

    # -- generation

    def init_state(self, batch: int, generator: torch.Generator | None = None, song: SongInputs | None = None) -> Any:
        """The song's audio memory, text spans, their encoded sentences and fusion weights."""
        device = self.prior.project.weight.device
        tokens = torch.zeros(batch, 0, dtype=torch.long, device=device)
        if song is None:
            return TokenState(tokens, None, grows=True)
        audio = self.prior.audio(to_tokens(song.latent, self.t))
        state = TokenState(tokens, audio, grows=False)
        table = self.text_table(song.spans, strict=False)
        if table is not None:
            index, ids = table
            self.lay_texts(state, index[:, token_middles(index.shape[1], self.t, audio.shape[1]).to(index.device)],
                            ids)
        return state

    def lay_texts(self, state: TokenState, index: torch.Tensor, ids: torch.Tensor) -> None:
        """Fill the state's spans from the span in force at each token ``(B, N)`` and the spans' ids ``(S, W)``:
        one text memory per run of a span, its fusion weights over the run."""
        batch, n = index.shape
        span_of = torch.full((batch, n), -1, dtype=torch.long, device=index.device)
        weight = torch.zeros(batch, n, dtype=torch.float64, device=index.device)
        sentences = []
        for b in range(batch):
            for start, end, span in span_runs(index[b]):
                span_of[b, start:end] = len(sentences)
                weight[b, start:end] = fusion_weights(end - start, self.config.fusion, self.config.ramp)
                sentences.append(ids[span])
        if sentences:
            state.text_memory, state.text_mask = self.prior.text(torch.stack(sentences))
            state.span_of, state.weight = span_of, weight

    def step(
        self,
        latent: torch.Tensor,
        history: torch.Tensor,
        state: TokenState | None,
        temperature: float = 1.0,
        generator: torch.Generator | None = None,
    ) -> tuple[torch.Tensor, TokenState]:
        """Sample the next token; its frames are the last ``t`` of the VQ-VAE decoding so far."""
        if state is None:
            state = self.init_state(latent.shape[0], generator)
        if state.grows:
            new = self.prior.audio(to_tokens(latent, self.t)[:, :1])
            state.audio = new if state.audio is None else torch.cat([state.audio, new], dim=1)
        self.next_token(state, state.audio, 0, temperature, generator)
        past, _ = self.tokenizer.receptive_field()
        frames = self.tokenizer.decode(state.tokens[:, -(past + 1) :])[:, -self.t :]
        return frames, state

    def next_token(self, state: TokenState, audio: torch.Tensor, first: int, temperature: float = 1.0,
                   generator: torch.Generator | None = None) -> torch.Tensor:
        """Sample the next token ``(B,)`` and append it to ``state.tokens``, the decoder reading the audio
        memory ``audio (B, M, dim)`` (projected), the song's audio tokens ``first .. first + M - 1``
        (``first`` > 0: a window of the song, live)."""
        i = state.tokens.shape[1]
        bos = state.tokens.new_full((state.tokens.shape[0], 1), self.prior.bos)
        seq = torch.cat([bos, state.tokens], dim=1)
        context = self.config.prior.context
        if context is not None:
            seq = seq[:, -context:]
        positions = torch.arange(i + 1 - seq.shape[1], i + 1, device=seq.device)
        audio, audio_positions = self._audio_window(audio, positions, first)
        hidden = self.prior.hidden_audio(seq, positions, audio, audio_positions)[:, -1]
        if state.weight is not None and i < state.weight.shape[1]:
            w = state.weight[:, i]
            rows = (w > 0).nonzero().flatten()
            if len(rows):  # the text branch runs only where the text weighs, and draws no random numbers
                span = state.span_of[rows, i]
                text = self.prior.hidden_text(seq[rows], positions, state.text_memory[span],
                                              state.text_mask[span])[:, -1]
                wr = w[rows, None].to(hidden.dtype)
                hidden = hidden.clone()
                hidden[rows] = wr * text + (1 - wr) * hidden[rows]
        token = sample_top_k(self.prior.logits(hidden), self.config.top_k, temperature, generator)
        state.tokens = torch.cat([state.tokens, token[:, None]], dim=1)
        return token

    def _audio_window(self, audio: torch.Tensor, positions: torch.Tensor,
                      first: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
        """The audio tokens the queries at ``positions`` can reach (of ``audio``, the song's tokens from
        ``first`` on), and their positions."""
        radius, last = self.config.prior.radius, first + audio.shape[1]
        lo, hi = first, last
        if radius is not None:
            lo = max(first, min(int(positions[0]) - radius, last - 1))
            hi = min(last, int(positions[-1]) + radius + 1)
        return audio[:, lo - first : hi - first], torch.arange(lo, hi, device=audio.device)

    def live_stream(self, encoder, lookahead: int | None = None, generator: torch.Generator | None = None,
                    temperature: float = 1.0):
        """``dance live``'s generation (:class:`dance_tokens.live.TokenStream`, ``lookahead`` in frames), or None
        when the audio encoder or the prior's audio attention is global (a token reads the whole song)."""
        reach = getattr(encoder, "reach", None)
        reach = reach() if reach is not None else None
        if reach is None or self.config.prior.radius is None:
            return None
        from dance_tokens.live import TokenStream

        return TokenStream(self, encoder, reach, lookahead, generator, temperature)

    def finish(self, motion: torch.Tensor, state: TokenState) -> torch.Tensor:
        """Motion ``(B, n, D)`` with its generated frames replaced by the joint decoding of every token
        (frames before ``n - t · tokens``, none when generation starts at frame 0 as it does here, kept)."""
        if state is None or state.tokens.shape[1] == 0:
            return motion
        decoded = self.tokenizer.decode(state.tokens).to(motion.dtype)
        n = motion.shape[1]
        start = max(0, n - decoded.shape[1])
        out = motion.clone()
        out[:, start:] = decoded[:, : n - start]
        return out


def build(config, *, motion_dim: int, latent_dim: int, window=None, cond_dims=None, **_: Any) -> TM2DHead:
    """Build the ``tm2d`` head; it needs a song-level encoder (``tm2d-audio``: one latent per frame)."""
    if window is not None and not window.song_level:
        raise ValueError("needs a song-level encoder such as tm2d-audio (one latent per frame), got a windowed one")
    name = config.text_stream
    if cond_dims is not None and name is not None and name not in cond_dims:
        raise ValueError(f"text_stream: the features have no stream {name!r} (streams: "
                         f"{', '.join(cond_dims) or 'none'}); add word-tokens under features.{name} or set "
                         "model.head.text_stream: null for music only")
    return TM2DHead(config, motion_dim, latent_dim)
