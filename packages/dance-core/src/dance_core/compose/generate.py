"""Generating a song's dances with a loaded model: one song at a time, or several songs in one batch."""

from __future__ import annotations

import numpy as np
import torch

from dance_core.compose.songs import Song
from dance_core.errors import DanceError
from dance_core.model import ComposedModel
from dance_core.recipe.schema import Recipe
from dance_core.row_generators import RowGenerators, supports_row_generators
from dance_core.runtime import generation_threads
from dance_core.spans import TextSpans


def batching_note(model: ComposedModel) -> str | None:
    """Why this model's songs cannot share a batch (``compose.batch_songs``), or None when they can: the
    head must draw its noise per row (:func:`dance_core.row_generators.supports_row_generators`) and the
    encoder must be windowed (a song-level encoder has no padding mask and would read the padding)."""
    head = type(model.head).__name__
    if model.window.song_level:
        return f"the encoder ({type(model.encoder).__name__}) reads the whole song, padding included"
    if not supports_row_generators(model.head):
        return f"the head ({head}) does not declare per-row random streams (row_generators)"
    return None


def _generate(model: ComposedModel, streams: dict, frames: int, seed: torch.Tensor, rows: int, recipe: Recipe,
              device: torch.device, generator, spans, progress, forced=None) -> np.ndarray:
    """The model's generation of ``rows`` dances of ``frames`` frames from one seed motion, with the
    recipe's sampling options and global torch seed; ``(rows, frames, D)`` as NumPy. ``forced``: NumPy
    values and mask ``(frames, D)`` the model takes as given (``ComposedModel.generate``)."""
    torch.manual_seed(recipe.seed)
    if forced is not None:
        values, mask = (torch.from_numpy(np.ascontiguousarray(a)).to(device) for a in forced)
        forced = (values.unsqueeze(0).expand(rows, -1, -1), mask)
    motion = model.generate(streams, frames, seed.unsqueeze(0).expand(rows, -1, -1).to(device),
                            temperature=recipe.compose.temperature, keep=recipe.compose.keep, generator=generator,
                            progress=progress, spans=spans, forced=forced)
    return motion.float().cpu().numpy()


def lead_in(model: ComposedModel, recipe: Recipe, song: Song, forced=None) -> int:
    """Frames danced before the song's start (``compose.lead_in``) and dropped, so that the dance is
    under way at its first frame instead of rising from the seed: twice the model's start frames (the
    seed, then as long again to get going) for a windowed model; 0 for a song-level one, with text spans
    or edits (their frames are the song's), or when not asked. Without it a dance rises from its seed
    over its first seconds (the bundled default: limbs at 0.02 m/s for 2 s, 0.4 once dancing)."""
    if not recipe.compose.lead_in or model.window.song_level or song.texts or forced is not None:
        return 0
    return 2 * model.start_frames()


def _lead(values: np.ndarray, lead: int) -> np.ndarray:
    """A stream with ``lead`` frames of the song's own opening before it (a pre-roll: the opening played
    once more, repeated when the song is shorter), so the lead-in is danced to this song's music."""
    if not lead:
        return values
    reps = int(np.ceil(lead / max(len(values), 1)))
    return np.concatenate([np.concatenate([values] * reps)[:lead], values])


def generate_song(
    model: ComposedModel, song: Song, seed: torch.Tensor, recipe: Recipe, device: torch.device,
    progress=None, forced=None,
) -> np.ndarray:
    """``compose.samples`` dances of one song, ``(samples, frames, D)`` normalized (``forced``: values and
    mask ``(frames, D)`` taken as given, :meth:`dance_core.compose.edits.Edits.forced`).

    Each song is generated on its own, its samples as one batch, with the random generator seeded
    from the recipe's seed: a song's dance does not depend on the other songs in the call.
    """
    c = recipe.compose
    lead = lead_in(model, recipe, song, forced)
    streams = {
        name: torch.from_numpy(np.ascontiguousarray(np.repeat(_lead(values, lead)[None], c.samples, axis=0)))
        .to(device)
        for name, values in song.streams.items()
    }
    # a lead-in only without texts, so the span table (no span in force anywhere) is lengthened by it
    spans = None if song.spans is None else TextSpans.stack([song.spans.extend(lead + song.n_frames)] * c.samples,
                                                            device)
    generation_threads(model, c.samples, device, c.threads)
    generator = torch.Generator(device=device).manual_seed(recipe.seed)
    motion = _generate(model, streams, lead + song.n_frames, seed, c.samples, recipe, device, generator, spans,
                       progress, forced)[:, lead:]
    if not np.all(np.isfinite(motion)):
        raise DanceError(f"{song.path or song.name}: the model produced NaN or inf motion; nothing was written")
    return motion


def generate_songs(
    model: ComposedModel, songs: list[Song], seed: torch.Tensor, recipe: Recipe, device: torch.device,
    progress=None,
) -> list[np.ndarray]:
    """``compose.samples`` dances of each of several songs generated in one batch, one ``(samples,
    frames, D)`` array per song (normalized), each trimmed to its song's length.

    Each song's music is padded with its last frame to the longest song (past its own end it is
    what per-song generation reads there too), and its rows draw from their own generator, seeded as
    :func:`generate_song` seeds it (:class:`RowGenerators`), so each song gets the noise it would get
    alone. Its frames equal per-song generation within float rounding (a row's product is not
    bit-identical at another batch size), and are deterministic for a given batch of songs. Only for
    models :func:`batching_note` accepts."""
    c = recipe.compose
    lead = min(lead_in(model, recipe, song) for song in songs)
    longest = max(song.n_frames for song in songs)
    names = list(songs[0].streams)
    streams = {}
    for name in names:
        rows = []
        for song in songs:
            values = _lead(song.streams[name], lead)
            if len(values) < lead + longest:
                values = np.concatenate([values, np.repeat(values[-1:], lead + longest - len(values), axis=0)])
            rows.append(np.repeat(values[None], c.samples, axis=0))
        streams[name] = torch.from_numpy(np.ascontiguousarray(np.concatenate(rows))).to(device)
    spans = None
    if all(song.spans is not None for song in songs):  # each song's spans run on over its padding, as its music
        spans = TextSpans.stack([song.spans.extend(lead + longest) for song in songs for _ in range(c.samples)],
                                device)
    batch = len(songs) * c.samples
    generation_threads(model, batch, device, c.threads)
    generator = RowGenerators.same_seed(recipe.seed, len(songs), c.samples, device)
    motion = _generate(model, streams, lead + longest, seed, batch, recipe, device, generator, spans,
                       progress)[:, lead:]
    out = []
    for k, song in enumerate(songs):
        part = motion[k * c.samples : (k + 1) * c.samples, : song.n_frames]
        if not np.all(np.isfinite(part)):
            raise DanceError(f"{song.path or song.name}: the model produced NaN or inf motion; nothing was written "
                             "for it")
        out.append(part)
    return out
