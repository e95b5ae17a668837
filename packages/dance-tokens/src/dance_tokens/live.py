"""TM2D live (``dance live``): tokens sampled as the music arrives, with a fixed look-ahead.

With a banded audio encoder (``radius``) and a banded audio cross-attention in the prior
(``prior.radius``), the token at ``i`` reads the audio memory up to token ``i + prior.radius``, whose
encoding reads music up to token ``i + prior.radius + radius · layers``: a bounded neighbourhood.
:class:`TokenStream` samples token ``i`` once the music ``ahead`` tokens past it is known, running the
encoder on a sliding window of the music received (as far back as the tokens the decoder still reads
reach, with the song's own positions), and gives token ``j``'s ``t`` frames once the tokens up to
``j + decode_ahead`` are sampled, decoding the tokens around it (the VQ-VAE's receptive field).

With the whole reach (``ahead = prior.radius + radius · layers``, ``decode_ahead`` the decoder's future
field), fed ``dance compose``'s features, its tokens are compose's and its frames equal compose's within
1e-4 (the decoder's convolutions over a window round differently; tested); with less the encoder and prior see the
music window cut at what has arrived (as at the end of a training segment or of a song), and a token's
frames are decoded without the tokens after the look-ahead. Defaults: :data:`AHEAD` and
:data:`DECODE_AHEAD` (docs/live.md has the figures).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import torch

from dance_tokens.rate import to_tokens, token_middles

#: default music look-ahead past a token's last frame, in tokens (8 frames at 30 fps: 0.27 s each): none.
#: Simulated on seven songs, 0, 2, 4 tokens and the whole reach (24) gave the same beat locking and jerk
#: within what one song moves them by (docs/live.md), so the shortest wait
AHEAD = 0
#: tokens sampled after a token before its frames are decoded: the decoder's future field (4 for tm2d-small),
#: so a frame is the joint decoding's; fewer left the token edges in (jerk 1.5-3.3x offline's at 3-1)
DECODE_AHEAD = 4


class TokenStream:
    """The ``tm2d`` head's :class:`dance_core.protocols.LiveStream`: see the module."""

    def __init__(self, head, encoder, reach: int, lookahead: int | None, generator, temperature: float):
        from dance_tokens.head import TokenState

        self.head, self.encoder, self.tt = head, encoder, head.t
        self.generator, self.temperature = generator, temperature
        self.radius, self.context = head.config.prior.radius, head.config.prior.context or 1 << 30
        self.reach = reach
        full = self.radius + reach
        self.ahead = min(full, AHEAD if lookahead is None else math.ceil(max(lookahead, 0) / self.tt))
        self.decode_past, future = head.tokenizer.receptive_field()
        self.decode_ahead = future if self.ahead >= full else min(future, DECODE_AHEAD)
        self.lookahead = (self.ahead + self.decode_ahead + 1) * self.tt - 1
        device = head.prior.project.weight.device
        self.state = TokenState(torch.zeros(1, 0, dtype=torch.long, device=device), None, grows=False)
        self.music: dict[str, torch.Tensor] | None = None  # conditioned music from song frame `offset`
        self.offset = 0  # a multiple of t
        self.frames = 0  # music frames received
        self.ended = False
        self.t = 0

    # -- what is known

    def _total(self) -> int:
        """Tokens of the whole song (known once it ended)."""
        return -(-self.frames // self.tt)

    def _sampleable(self) -> int:
        """Tokens whose music (and look-ahead) is known."""
        return self._total() if self.ended else max(0, self.frames // self.tt - self.ahead)

    def _givable(self) -> int:
        """Tokens whose frames may go out."""
        if self.ended:
            return self._total()
        return max(0, self._sampleable() - self.decode_ahead)

    def add(self, cond: Mapping[str, torch.Tensor]) -> None:
        """Append conditioned music frames ``{stream: (1, k, C)}``."""
        k = next(iter(cond.values())).shape[1]
        if k == 0:
            return
        self.music = dict(cond) if self.music is None else {n: torch.cat([self.music[n], v], 1)
                                                               for n, v in cond.items()}
        self.frames += k

    def end(self) -> None:
        """No more music: the last frame is repeated for one token, as ``dance compose`` pads the song."""
        if not self.ended and self.music is not None:
            self.music = {n: torch.cat([v, v[:, -1:].expand(-1, self.tt, -1)], 1) for n, v in self.music.items()}
        self.ended = True

    def ready(self) -> int:
        """Frames that may be given now."""
        last = min(self._givable() * self.tt, self.frames) if self.ended else self._givable() * self.tt
        return max(0, last - self.t)

    def newest(self, frame: int) -> int:
        """The last music frame frame ``frame`` waits for (the song's last once it ended)."""
        return (frame // self.tt + self.decode_ahead + self.ahead + 1) * self.tt - 1

    def first_open(self) -> int:
        """The first frame of the first token not sampled yet."""
        return self.state.tokens.shape[1] * self.tt

    # -- generation

    @torch.inference_mode()
    def step(self) -> torch.Tensor:
        """The next token's frames ``(k, D)``; empty when none is ready."""
        if self.ready() <= 0:
            return torch.zeros(0, self.head.tokenizer.decoder[-1].out_channels)
        j = self.t // self.tt
        last = min(j + self.decode_ahead, self._sampleable() - 1)
        while self.state.tokens.shape[1] <= last:
            self._sample()
        lo = max(0, j - self.decode_past)
        decoded = self.head.tokenizer.decode(self.state.tokens[:, lo : last + 1])
        stop = min((j + 1) * self.tt, self.frames) if self.ended else (j + 1) * self.tt
        out = decoded[0, self.t - lo * self.tt : stop - lo * self.tt]
        self.t = stop
        self._trim()
        return out

    def _sample(self) -> None:
        """Sample the next token from the music known now."""
        i = self.state.tokens.shape[1]
        known = -(-(self.frames + self.tt) // self.tt) if self.ended else self.frames // self.tt
        first = max(0, i + 1 - self.context)  # the first position the decoder's context reads
        a_lo, a_hi = max(0, min(first - self.radius, known - 1)), min(known, i + self.radius + 1)
        e_lo, e_hi = max(0, a_lo - self.reach), min(known, a_hi + self.reach)
        rows = slice(e_lo * self.tt - self.offset, e_hi * self.tt - self.offset)
        latent = self.encoder(None, {n: v[:, rows] for n, v in self.music.items()}, e_lo)
        audio = self.head.prior.audio(to_tokens(latent, self.tt))[:, a_lo - e_lo : a_hi - e_lo]
        self.head.next_token(self.state, audio, a_lo, self.temperature, self.generator)

    def skip(self, n: int) -> None:
        """Drop the next ``n // t`` tokens' frames: tokens not sampled yet repeat the last one (no compute)."""
        k = min(n // self.tt, max(0, self._givable() - self.t // self.tt))
        if k <= 0:
            return
        j = self.t // self.tt + k
        tokens = self.state.tokens
        if tokens.shape[1] < j:
            held = tokens[:, -1:] if tokens.shape[1] else tokens.new_zeros(1, 1)
            self.state.tokens = torch.cat([tokens, held.expand(-1, j - tokens.shape[1])], 1)
        self.t = j * self.tt
        self._trim()

    def _trim(self) -> None:
        """Forget music no later token reads."""
        i = self.state.tokens.shape[1]
        keep = max(0, i + 1 - self.context - self.radius - self.reach) * self.tt
        if self.music is not None and keep - self.offset > 256:
            self.music = {n: v[:, keep - self.offset :] for n, v in self.music.items()}
            self.offset = keep

    # -- text

    def texts(self, spans) -> None:
        """Lay the spans known now over the tokens (the tokens already sampled keep what they were)."""
        state = self.state
        state.span_of = state.weight = state.text_memory = state.text_mask = None
        table = self.head.text_table(spans, strict=False)
        if table is None:
            return
        index, ids = table
        index = torch.nn.functional.pad(index, (0, self.tt), value=-1)  # no span after the last one's end
        n = -(-index.shape[1] // self.tt)
        self.head.lay_texts(state, index[:, token_middles(index.shape[1], self.tt, n).to(index.device)], ids)
