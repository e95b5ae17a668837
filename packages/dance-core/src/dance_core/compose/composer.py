"""``Composer``: a trained model loaded once, composing in memory for scripts and benchmarks.

Each step is the one ``dance compose`` takes (``compose.songs``, ``compose.generate``,
``compose.output``), with the recipe's ``compose:`` settings, so a script can time or inspect any
of them: a song's features, its dances generated, decoded and grounded, or written as files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch

from dance_core.compose.generate import generate_song, generate_songs
from dance_core.compose.inputs import beside_recipe
from dance_core.compose.output import finished, write_song
from dance_core.compose.songs import Song, beat_tracker_of, load_model, load_song, seed_motion
from dance_core.errors import RecipeError
from dance_core.protocols import MotionData
from dance_core.recipe.schema import Recipe, TextSpec
from dance_core.registry import get_registry
from dance_core.runtime import pick_device


class Composer:
    """The recipe's model with a checkpoint (default ``compose.checkpoint``) on ``device`` (default
    ``compose.device``, with ``compose.threads``). Attributes: ``recipe``, ``model`` (a
    ``ComposedModel``), ``checkpoint`` (its ``Checkpoint``: statistics, ``motion`` description),
    ``stack`` (the feature extractors), ``device``, ``registry``."""

    def __init__(self, recipe: Recipe, checkpoint: str | Path | None = None, device: str | None = None):
        c = recipe.compose
        path = checkpoint or (recipe.resolve_path(c.checkpoint) if c.checkpoint else None)
        if path is None:
            raise RecipeError(f"{recipe.origin}: compose.checkpoint: no model given")
        self.recipe = recipe
        self.registry = get_registry()
        self.device = pick_device(device or c.device, c.threads)
        self.model, self.checkpoint, self.stack = load_model(recipe, path, self.device)

    def seed(self, spec: str | None = None) -> torch.Tensor:
        """The normalized seed motion ``(S, D)``: ``rest`` (the mean pose), a motion file, or by default
        ``compose.seed_motion`` (a file as given, else beside the recipe)."""
        spec = beside_recipe(spec if spec is not None else self.recipe.compose.seed_motion, self.recipe)
        values = seed_motion(spec, self.checkpoint, self.model.start_frames(), self.registry,
                             self.recipe.format_options)
        return torch.from_numpy(values)

    def song(self, path: str | Path, seconds: float | None = None, texts: list[TextSpec] | None = None,
             start: float | None = None) -> Song:
        """A song's standardized features (``seconds``, ``texts``, ``start``: default the recipe's ``compose:``
        values)."""
        c, tracker = self.recipe.compose, beat_tracker_of(self.recipe, self.registry)
        return load_song(str(path), self.stack, self.checkpoint, c.seconds if seconds is None else seconds,
                         self.registry, c.texts if texts is None else texts, tracker,
                         c.start if start is None else start)

    def generate(self, song: Song, seed: torch.Tensor | None = None, progress: Any = None) -> np.ndarray:
        """``compose.samples`` dances of one song ``(samples, frames, D)``, normalized, as ``dance compose``
        generates them (the same bytes)."""
        seed = self.seed() if seed is None else seed
        return generate_song(self.model, song, seed, self.recipe, self.device, progress)

    def generate_batch(self, songs: list[Song], seed: torch.Tensor | None = None) -> list[np.ndarray]:
        """Several songs' dances generated in one batch (``compose.batch_songs``; see ``generate_songs``)."""
        seed = self.seed() if seed is None else seed
        return generate_songs(self.model, songs, seed, self.recipe, self.device)

    def dances(self, song: Song, motion: np.ndarray, ground: bool | None = None) -> list[MotionData]:
        """Each generated dance of a song decoded (de-normalized, skeletal motion attached) and, with
        ``ground`` (default ``compose.ground``), on the floor with its feet pinned, as written."""
        info, out = self.checkpoint.motion, []
        for k in range(motion.shape[0]):
            data = info.decode(self.checkpoint.stats.motion.invert(motion[k, : song.n_frames]), self.recipe.fps,
                               self.registry)
            out.append(finished(data, song, info, self.registry, self.recipe, ground))
        return out

    def write(self, song: Song, motion: np.ndarray, out_dir: str | Path, stems: list[str] | None = None) -> list[Path]:
        """Write a song's dances in ``compose.formats`` into ``out_dir`` as one output set (stems default
        ``SONG-k``); returns the motion files written."""
        formats = [(entry, self.recipe.format_options.build(entry))
                   for entry in (self.registry.find("motion-format", f) for f in self.recipe.compose.formats)]
        stems = stems or [f"{song.name}-{k}" for k in range(motion.shape[0])]
        return write_song(song, motion, stems, Path(out_dir), formats, self.checkpoint, self.recipe, self.registry)
