"""Streaming generation: the model steps one frame (or ``keep`` frames) as soon as the music it reads
is known, keeping its state (the head's, e.g. the flow's correlated noise, and the motion history).

It is :meth:`dance_core.model.ComposedModel.generate`'s windowed loop cut open: the step for frame
``t`` reads the music frames ``t - cond_past .. t + cond_future - 1`` (the first frame repeated before
the song, the last after it, as offline), so a frame waits for ``cond_future`` frames of music (the
Transflower recipes: 10 frames, 0.5 s). Fed the same features, it gives the same frames as ``dance
compose`` with one sample (tested).

Behind a song-level encoder the head's ``live_stream`` hook (:class:`dance_core.protocols.LiveStream`)
does the stepping, when the encoder's latent reads a bounded neighbourhood of music (TM2D's banded
encoder, with a look-ahead of its own); one that reads the whole song at once (DanceRevolution's
bidirectional encoder) cannot run live.
"""

from __future__ import annotations

import numpy as np
import torch

from dance_core.errors import DataError
from dance_core.model import ComposedModel
from dance_core.recipe.schema import Recipe


class LiveGenerator:
    """The model's frames, generated as music frames arrive: ``add(streams)`` appends standardized
    feature frames, ``ready()`` says how many frames may be generated now, ``step()`` generates the
    next ones (normalized ``(k, D)`` NumPy), ``skip(n)`` drops ``n`` frames (the last pose is held in
    the history the model reads), ``end()`` marks the end of the music (its last frame is repeated)."""

    def __init__(self, model: ComposedModel, recipe: Recipe, seed: torch.Tensor, device: torch.device,
                 lookahead: int | None = None):
        w, head = model.window, model.head
        self.model, self.device = model, device
        self.temperature = recipe.compose.temperature
        torch.manual_seed(recipe.seed)
        self.generator = torch.Generator(device=device).manual_seed(recipe.seed)
        self.stream = None  # a song-level model's LiveStream (lookahead: its music look-ahead in frames)
        if w.song_level:
            hook = getattr(head, "live_stream", None)
            self.stream = hook(model.encoder, lookahead, self.generator, self.temperature) if hook else None
            if self.stream is None:
                why = "reads the whole song at once" if hook else \
                    f"is song-level and the head ({type(head).__name__}) has no live form"
                raise DataError(f"live: the encoder ({type(model.encoder).__name__}) {why}; it cannot dance live "
                                "(windowed encoders can: Transflower, MoGlow, window-mlp; and tm2d-audio with a "
                                "radius)")
            self.lookahead = self.stream.lookahead
            return
        self.lookahead = w.cond_future  # frames of music past a frame's own that it waits for
        self.keep = min(recipe.compose.keep or head.keep, head.frames)
        self.state = head.init_state(1, self.generator)
        self.start = model.start_frames()
        self.memory = max(w.motion_past, head.history_frames)
        self.motion = seed[seed.shape[0] - self.start :].to(device).unsqueeze(0)  # (1, S, D) recent motion
        self.t = 0  # frames given out so far (the seed's first)
        self.cond: dict[str, torch.Tensor] | None = None  # conditioned music, frame 0 = song frame `offset`
        self.offset = -w.cond_past  # song frame of cond's row 0 (negative: the first frame repeated)
        self.frames = 0  # music frames received
        self.ended = False

    def add(self, streams: dict[str, np.ndarray]) -> None:
        """Append standardized feature frames ``{stream: (k, dim)}``."""
        k = len(next(iter(streams.values())))
        if k == 0:
            return
        x = self.model.condition({n: torch.from_numpy(np.ascontiguousarray(v))[None].to(self.device)
                                  for n, v in streams.items()})
        if self.stream is not None:
            self.stream.add(x)
            return
        if self.cond is None:  # the song's first frame stands in for the frames before it
            w = self.model.window
            x = {n: torch.cat([v[:, :1].expand(-1, w.cond_past, -1), v], 1) for n, v in x.items()}
            self.cond = x
        else:
            self.cond = {n: torch.cat([self.cond[n], v], 1) for n, v in x.items()}
        self.frames += k

    def end(self) -> None:
        """No more music: later steps read its last frame repeated."""
        if self.stream is not None:
            self.stream.end()
            return
        self.ended = True

    @property
    def t(self) -> int:
        """Frames given out (or skipped) so far."""
        return self.stream.t if self.stream is not None else self._t

    @t.setter
    def t(self, value: int) -> None:
        self._t = value

    def newest(self, frame: int) -> int:
        """The last music frame that frame ``frame`` waits for."""
        return self.stream.newest(frame) if self.stream is not None else frame + self.lookahead - 1

    def first_open(self) -> int:
        """The first frame not generated yet (a text span given now can act from there on)."""
        return self.stream.first_open() if self.stream is not None else self.t

    def texts(self, spans) -> None:
        """The text spans known now (a ``TextSpans`` of one row from the song's start) for a song-level head
        that reads them; windowed models read text as per-frame streams (``LiveFeatures``)."""
        if self.stream is not None:
            self.stream.texts(spans)

    def ready(self) -> int:
        """Frames that may be given now (their music window is known)."""
        if self.stream is not None:
            return self.stream.ready()
        if self.ended:
            return max(0, self.frames - self.t)
        return max(0, self.frames - self.model.window.cond_future + 1 - self.t)

    def skip(self, n: int) -> None:
        """Drop the next ``n`` frames: the last pose is held in the history."""
        if self.stream is not None:
            self.stream.skip(n)
            return
        n = min(n, max(0, self.frames - self.t)) if self.ended else n
        if n <= 0:
            return
        if self.t + n > self.start:
            held = self.motion[:, -1:].expand(-1, n, -1)
            self.motion = torch.cat([self.motion, held], 1)[:, -self.memory :]
        self.t += n
        self._trim()

    @torch.inference_mode()
    def step(self) -> np.ndarray:
        """The next frames, ``(k, D)`` normalized (the seed's frames first); empty when none is ready."""
        if self.stream is not None:
            out = self.stream.step().float().cpu().numpy()
            if not np.all(np.isfinite(out)):
                raise DataError(f"live: the model produced NaN or inf motion at frame {self.t - len(out)}")
            return out
        if self.ready() <= 0:
            return np.zeros((0, self.motion.shape[2]), np.float32)
        if self.t < self.start:  # the seed motion fills the first frames
            k = min(self.ready(), self.start - self.t)
            out = self.motion[0, self.motion.shape[1] - self.start + self.t :][:k]
            self.t += k
            return out.float().cpu().numpy()
        w, head = self.model.window, self.model.head
        lo = self.t - self.offset - w.cond_past
        window = {n: self._rows(v, lo, w.cond_past + w.cond_future) for n, v in self.cond.items()}
        latent = self.model.encoder(self.motion[:, -w.motion_past :] if w.motion_past else self.motion[:, :0], window)
        history = self.motion[:, self.motion.shape[1] - head.history_frames :]
        frames, self.state = head.step(latent, history, self.state, self.temperature, self.generator)
        k = min(self.keep, self.ready())
        new = frames[:, :k]
        self.motion = torch.cat([self.motion, new], 1)[:, -self.memory :]
        self.t += k
        self._trim()
        out = new[0].float().cpu().numpy()
        if not np.all(np.isfinite(out)):
            raise DataError(f"live: the model produced NaN or inf motion at frame {self.t - k}")
        return out

    def _rows(self, x: torch.Tensor, lo: int, n: int) -> torch.Tensor:
        """Rows ``lo .. lo + n - 1`` of a conditioned stream, its last row repeated past its end."""
        part = x[:, lo : lo + n]
        if part.shape[1] < n:
            part = torch.cat([part, x[:, -1:].expand(-1, n - part.shape[1], -1)], 1)
        return part

    def _trim(self) -> None:
        """Forget music no later step reads."""
        w = self.model.window
        drop = self.t - self.offset - w.cond_past
        if self.cond is not None and drop > 256:
            self.cond = {n: v[:, drop:] for n, v in self.cond.items()}
            self.offset += drop
