"""The composed model: conditioners -> encoder -> head, with one training loss and one generator."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from dance_core.contexts import ConditionerContext, EncoderContext, HeadContext
from dance_core.errors import RecipeError
from dance_core.protocols import SongInputs, TrainContext
from dance_core.recipe.schema import Recipe
from dance_core.spans import TextSpans


def build_model(recipe: Recipe, motion_dim: int, stream_dims: Mapping[str, int]) -> ComposedModel:
    """Build every component named by the recipe's ``model:`` and chain them."""
    conditioners = {}
    for name, spec in recipe.model.conditioners.items():
        if name not in stream_dims:
            raise RecipeError(
                f"{recipe.origin}: model.conditioners.{name}: no feature stream {name!r} "
                f"(streams: {', '.join(stream_dims) or 'none'})"
            )
        conditioners[name] = _build(spec, f"model.conditioners.{name}", ConditionerContext(name, stream_dims[name]))
    cond_dims = {n: conditioners[n].out_dim if n in conditioners else d for n, d in stream_dims.items()}
    encoder = _build(recipe.model.encoder, "model.encoder", EncoderContext(motion_dim, cond_dims))
    head = _build(
        recipe.model.head,
        "model.head",
        HeadContext(motion_dim, encoder.out_dim, encoder.latent_tokens, encoder.window, cond_dims),
    )
    want = getattr(head, "latent_tokens", None)
    # a song-level encoder gives one token per frame, so a head needing K tokens per step gets its `frames`
    gives = head.frames if encoder.window.song_level else encoder.latent_tokens
    if want is not None and want != gives:
        raise RecipeError(
            f"{recipe.origin}: model.head: {recipe.model.head.plugin} needs {want} latent tokens "
            f"but {recipe.model.encoder.plugin} gives {gives}"
        )
    return ComposedModel(conditioners, encoder, head)


def _build(spec, where: str, context: Any):
    try:
        return spec.build(context)
    except (ValueError, TypeError) as exc:
        raise RecipeError(f"{where}: {spec.plugin}: {exc}") from exc


def _edge_pad(x: torch.Tensor, before: int, after: int) -> torch.Tensor:
    """Pad the time axis of ``(B, T, C)`` by repeating the first and last frames."""
    if before == 0 and after == 0:
        return x
    return F.pad(x.transpose(1, 2), (before, after), mode="replicate").transpose(1, 2)


def frame_dropout(x: torch.Tensor, p: float, generator: torch.Generator | None = None) -> torch.Tensor:
    """``(B, T, C)`` with each frame zeroed with probability ``p`` (the reference's input dropouts)."""
    if p <= 0:
        return x
    keep = torch.rand(x.shape[:2], generator=generator, device=generator.device if generator else None) >= p
    return x * keep.to(x.device, x.dtype).unsqueeze(-1)


def motion_noise(x: torch.Tensor, std: float, generator: torch.Generator | None = None) -> torch.Tensor:
    """``(B, T, C)`` plus Gaussian noise whose std is drawn per segment from ``U(0, std)``, so the model
    sees past motion from exact to as wrong as its own samples may be."""
    if std <= 0:
        return x
    dev = generator.device if generator else None
    scale = torch.rand(x.shape[0], 1, 1, generator=generator, device=dev) * std
    noise = torch.randn(x.shape, generator=generator, device=dev) * scale
    return x + noise.to(x.device, x.dtype)


def _aligned_windows(
    latent: torch.Tensor, motion: torch.Tensor, history: int, frames: int
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Consecutive ``frames``-frame windows of a song-level segment after its first ``history``
    frames, folded into the batch: latent ``(B*W, frames, d)``, target and history motion."""
    starts = range(history, motion.shape[1] - frames + 1, frames)

    def fold(x: torch.Tensor, before: int, length: int) -> torch.Tensor:
        return torch.stack([x[:, s - before : s - before + length] for s in starts], 1).flatten(0, 1)

    return fold(latent, 0, frames), fold(motion, 0, frames), fold(motion, history, history)


class ComposedModel(nn.Module):
    """Chains conditioners, an encoder and an output head; see docs/architecture.md."""

    def __init__(self, conditioners: Mapping[str, nn.Module], encoder: nn.Module, head: nn.Module):
        super().__init__()
        self.conditioners = nn.ModuleDict(dict(conditioners))
        self.encoder = encoder
        self.head = head
        self.window = encoder.window

    def condition(self, streams: Mapping[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """Run each stream through its conditioner (streams without one pass through)."""
        return {n: self.conditioners[n](x) if n in self.conditioners else x for n, x in streams.items()}

    def _lead(self) -> int:
        w = self.window
        return max((w.cond_past or 0) - w.motion_past, 0)

    def segment_frames(self, song_segment: int | None) -> int:
        """Frames per training segment: the window plus the target, or ``data.segment_frames``."""
        w, head = self.window, self.head
        if w.song_level:
            if song_segment is None:
                raise RecipeError("data.segment_frames: required by a song-level encoder")
            if song_segment <= head.history_frames:
                raise RecipeError("data.segment_frames: must exceed the head's history frames")
            if head.latent_tokens is not None and song_segment < head.history_frames + head.frames:
                raise RecipeError("data.segment_frames: must hold the head's history and frames")
            return song_segment
        return self._lead() + w.motion_past + max(head.frames, w.cond_future)

    def training_loss(
        self, motion: torch.Tensor, streams: Mapping[str, torch.Tensor], ctx: TrainContext, augment: Any = None,
        spans: TextSpans | None = None,
    ) -> dict[str, torch.Tensor]:
        """The head's losses on one batch of aligned segments; ``augment`` (a recipe's
        ``training.augment``) corrupts the inputs, never the targets, with ``ctx.generator`` (the
        per-frame streams: ``spans``, the segments' text spans, are handed on as they are)."""
        w, head = self.window, self.head
        if augment is not None:
            drop = augment.input_dropout
            streams = {n: frame_dropout(x, drop.get(n, 0.0), ctx.generator) for n, x in streams.items()}
        cond = self.condition(streams)
        if w.song_level:
            h = head.history_frames
            latent = self.encoder(None, cond)
            if head.latent_tokens is None:  # a sequence head: the whole aligned segment at once
                ctx = replace(ctx, streams={n: x[:, h:] for n, x in cond.items()},
                              spans=None if spans is None else spans.crop(h))
                return head.loss(latent[:, h:], motion[:, h:], motion[:, :h], ctx)
            return head.loss(*_aligned_windows(latent, motion, h, head.frames), ctx)
        t = self._lead() + w.motion_past
        past = motion[:, :t]
        if augment is not None:
            past = motion_noise(past, augment.motion_noise, ctx.generator)
        window = {n: x[:, t - w.cond_past : t + w.cond_future] for n, x in cond.items()}
        seen = past[:, t - w.motion_past :]
        if augment is not None:
            seen = frame_dropout(seen, augment.input_dropout.get("motion", 0.0), ctx.generator)
        latent = self.encoder(seen, window)
        target = motion[:, t : t + head.frames]
        return head.loss(latent, target, past[:, t - head.history_frames :], ctx)

    def start_frames(self) -> int:
        """Frames the seed motion fills at the start of a generated dance."""
        return max(self.window.motion_past, self.head.history_frames)

    @torch.inference_mode()
    def generate(
        self,
        streams: Mapping[str, torch.Tensor],
        n_frames: int,
        seed: torch.Tensor,
        temperature: float = 1.0,
        keep: int | None = None,
        generator: torch.Generator | None = None,
        progress: Callable[[int], None] | None = None,
        spans: TextSpans | None = None,
        forced: tuple[torch.Tensor, torch.Tensor] | None = None,
    ) -> torch.Tensor:
        """Generate ``(B, n_frames, D)`` from streams ``(B, >=n_frames, C)`` and a seed ``(B, S, D)``;
        ``spans``, the text spans over the streams' frames, reach a head behind a song-level encoder.
        ``forced``: values ``(B, >=n_frames, D)`` and a boolean mask ``(>=n_frames, D)`` of what is given:
        those channels of those frames replace what the head makes as soon as it makes them, so the model
        continues from them (a dance's kept frames, a body part's channels)."""
        w, head = self.window, self.head
        batch = seed.shape[0]
        start = min(self.start_frames(), n_frames)
        if seed.shape[1] < start:
            raise ValueError(f"the seed motion needs {start} frames, got {seed.shape[1]}")
        out = seed.new_zeros(batch, n_frames, seed.shape[2])
        out[:, :start] = seed[:, seed.shape[1] - start :]
        if forced is not None:
            given, mask = forced[0][:, :n_frames].to(out), forced[1][:n_frames].to(out.device)
            out[:, :start] = torch.where(mask[:start], given[:, :start], out[:, :start])
        keep = min(keep or head.keep, head.frames)
        streams = {n: x[:, :n_frames] for n, x in streams.items()}
        h = head.history_frames
        if w.song_level:
            cond = self.condition({n: _edge_pad(x, 0, head.frames) for n, x in streams.items()})
            latent_all = self.encoder(None, cond)
            song_spans = None if spans is None else spans.crop(0, n_frames).pad(head.frames)
            state = head.init_state(batch, generator, song=SongInputs(latent_all, cond, song_spans))
        else:
            state = head.init_state(batch, generator)
            before, after = w.cond_past, w.cond_future + keep
            cond = self.condition({n: _edge_pad(x, before, after) for n, x in streams.items()})
        t = start
        while t < n_frames:
            if w.song_level:
                latent = latent_all[:, t : t + head.frames]
            else:
                window = {n: x[:, t : t + w.cond_past + w.cond_future] for n, x in cond.items()}
                latent = self.encoder(out[:, t - w.motion_past : t], window)
            frames, state = head.step(latent, out[:, t - h : t], state, temperature, generator)
            k = min(keep, n_frames - t)
            out[:, t : t + k] = frames[:, :k]
            if forced is not None:
                out[:, t : t + k] = torch.where(mask[t : t + k], given[:, t : t + k], out[:, t : t + k])
            t += k
            if progress is not None:
                progress(t)
        return head.finish(out, state)
