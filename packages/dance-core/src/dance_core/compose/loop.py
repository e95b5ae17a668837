"""The composition loop behind ``dance compose``: music in, motion files out.

Per song (this shard's part, skipping complete output sets unless ``overwrite``): features
(``compose.songs``), dances generated (``compose.generate``), decoded, grounded and written as one
output set (``compose.output``). What it reads is resolved once by ``compose.inputs``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

import torch

from dance_core.atomic import sweep_stale_temps
from dance_core.compose.edits import limits, plan_edits
from dance_core.compose.generate import batching_note, generate_song, generate_songs
from dance_core.compose.inputs import ComposeInputs, ComposeOptions, reads_text, resolve_inputs
from dance_core.compose.output import complete, manifest_path, output_stems, output_targets, write_song
from dance_core.compose.songs import beat_tracker_of, load_model, load_song, seed_motion
from dance_core.delivery import plan_delivery
from dance_core.errors import DanceError, RecipeError, describe_error
from dance_core.progress import progress_bar
from dance_core.recipe.schema import Recipe
from dance_core.registry import get_registry
from dance_core.runtime import pick_device
from dance_core.shards import Shard


@dataclass
class Composed:
    """What one composition call did: files written (dances, and the sidecars beside them), songs written,
    skipped and failed, frames generated."""

    written: list[Path] = field(default_factory=list)
    sidecars: list[Path] = field(default_factory=list)  #: ``.texts`` and ``.markers.json`` files written
    songs: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    shard: Shard | None = None
    failed: list[tuple[str, str]] = field(default_factory=list)  #: (song, why) with ``keep_going``


def compose(
    recipe: Recipe,
    music: list[str] | None = None,
    checkpoint: str | None = None,
    out_dir: str | None = None,
    quiet: bool = False,
) -> list[Path]:
    """Generate ``compose.samples`` dances per song and write them in every format asked for."""
    return compose_songs(recipe, music, checkpoint, out_dir, quiet).written


def compose_songs(
    recipe: Recipe,
    music: list[str] | None = None,
    checkpoint: str | None = None,
    out_dir: str | None = None,
    quiet: bool = False,
    *,
    overwrite: bool = True,
    shard: Shard | None = None,
) -> Composed:
    """Compose every song (files or folders of them), or this ``shard``'s part of them; each song's
    files are written as one output set as soon as its dances are generated. ``overwrite=False`` skips
    a song whose output set is complete (:func:`complete`) without loading the model for it.

    Each song is generated alone (:func:`generate_song`), so its dance is the same bytes whatever the
    other songs, their order or the shard. With ``compose.batch_songs`` k > 1 (and a head that draws
    per row, after a windowed encoder: :func:`batching_note`) k songs at a time share a batch
    (:func:`generate_songs`): equal to per-song generation within float rounding, not bit-identical."""
    options = ComposeOptions(music=music, checkpoint=checkpoint, out_dir=out_dir, overwrite=overwrite, shard=shard,
                             quiet=quiet)
    return run_compose(resolve_inputs(recipe, options))


def run_compose(inputs: ComposeInputs) -> Composed:
    """Compose resolved inputs (:func:`dance_core.compose.inputs.resolve_inputs`), as :func:`compose_songs` does."""
    recipe, options = inputs.recipe, inputs.options
    c = recipe.compose
    registry = get_registry()
    checkpoint = inputs.checkpoint
    if checkpoint is None:
        raise RecipeError(f"{recipe.origin}: compose.checkpoint: no model given (or pass --checkpoint)")
    songs_in = inputs.songs()
    if not songs_in:
        raise RecipeError(f"{recipe.origin}: compose.music: no song given (or pass --music)")
    if c.texts and not reads_text(recipe, registry):
        features = ", ".join(s.plugin for specs in recipe.features.values() for s in specs)
        raise RecipeError(f"{recipe.origin}: compose.texts: this model reads no text (features: {features}); "
                          "drop --text or use a recipe with a text feature such as tm2d-small")
    formats = [(entry, recipe.format_options.build(entry))
               for entry in (registry.find("motion-format", f) for f in c.formats)]
    delivery = plan_delivery(registry, inputs.rig, inputs.rig_map, fps=c.output_fps, units=c.units,
                             options=(_option(options, "rig", "--rig"), _option(options, "rig_map", "--rig-map"), ""),
                             up=c.up, formats=[entry.name for entry, _ in formats],
                             up_option=_option(options, "up", "--up"))
    if c.markers:
        _need_beat_tracker(recipe, registry, _option(options, "markers", "--markers"))
    if c.start and c.from_motion:
        raise RecipeError(f"{_option(options, 'start', '--start')}: not with "
                          f"{_option(options, 'from_motion', '--from')} (the dance to edit sets where its song starts)")
    stems = dict(zip(songs_in, output_stems(songs_in, c.samples), strict=True))  # every song's, before sharding
    shard = options.shard
    mine = shard.select(songs_in) if shard else songs_in
    out = Path(inputs.out_dir)
    result = Composed(songs=list(mine), shard=shard)
    todo = []
    for path in mine:
        targets = output_targets(out, stems[path], formats, bool(c.texts), c.markers)
        if not options.overwrite and complete(targets, manifest_path(out, path)):
            sweep_stale_temps(out, [t.name for t in targets])  # what a killed run left beside a whole set
            result.skipped.append(path)
        else:
            todo.append(path)
    if not todo:
        return result
    device = pick_device(c.device, c.threads)
    model, ckpt, stack = load_model(recipe, checkpoint, device)
    if (delivery.changes or c.markers) and ckpt.motion.skeleton is None:
        raise RecipeError(f"{recipe.origin}: compose.rig, output_fps, units, up and markers need a model of skeletal "
                          f"motion; {checkpoint} makes {ckpt.motion.representation or 'feature'} frames")
    labels = {name: _option(options, name, flag) for name, flag in EDIT_OPTIONS.items()}
    edits = plan_edits(recipe, ckpt, registry, labels)
    limits(model, edits, _option(options, "from_motion", "--from"))
    if edits.source is not None and len(todo) > 1:
        raise RecipeError(f"{_option(options, 'from_motion', '--from')}: one song at a time (the song of the dance "
                          f"to edit); {len(todo)} given")
    start = model.start_frames()
    seed_values = seed_motion(inputs.seed_motion, ckpt, start, registry, recipe.format_options)
    seed = torch.from_numpy(seed_values)
    tracker = beat_tracker_of(recipe, registry)
    per_batch = c.batch_songs
    note = batching_note(model) if per_batch > 1 and len(todo) > 1 else None
    if edits.any:
        per_batch, note = 1, None
    if note:
        per_batch = 1
        if not options.quiet:
            print(f"dance: note: compose.batch_songs={c.batch_songs}: {note}; composing one song at a time",
                  file=sys.stderr)
    with progress_bar(options.quiet) as bar:
        task = bar.add_task("compose", total=len(todo), info=f"{len(todo)} song(s) × {c.samples}") if bar else None
        done: set[str] = set()

        def batch(paths: list[str], i: int) -> None:
            """Load, generate and write these songs together (``done`` gains each one written)."""
            seconds = edits.source.duration if edits.source is not None else c.seconds
            songs = [load_song(path, stack, ckpt, seconds, registry, c.texts, tracker, c.start) for path in paths]
            for song in songs:  # keyframes and spans inside the song, before generating
                edits.check_song(song.n_frames, recipe.fps, song.path)
            n, k = max(song.n_frames for song in songs), len(songs)
            progress = (lambda t, i=i, n=n, k=k: bar.update(task, completed=i + k * t / n)) if bar else None
            if bar:
                names = ", ".join(song.name for song in songs)
                bar.update(task, info=f"{names} ({i + len(songs)}/{len(todo)}) × {c.samples}")
            if len(songs) == 1:
                forced = edits.forced(ckpt, registry, songs[0].n_frames)
                motions = [generate_song(model, songs[0], seed, recipe, device, progress, forced)]
            else:
                motions = generate_songs(model, songs, seed, recipe, device, progress)
            for path, song, motion in zip(paths, songs, motions, strict=True):
                result.written.extend(write_song(song, motion, stems[path], out, formats, ckpt, recipe, registry,
                                                 delivery, edits, result.sidecars))
                result.frames += c.samples * song.n_frames
                result.seconds += c.samples * song.n_frames / recipe.fps
                done.add(path)

        for i in range(0, len(todo), per_batch):
            paths = todo[i : i + per_batch]
            try:
                batch(paths, i)
            except SONG_FAILURES as exc:  # --keep-going: this song listed, the others written
                if not options.keep_going:
                    raise
                if len(paths) == 1:
                    result.failed.append((paths[0], describe_error(exc)))
                for path in [p for p in paths if p not in done] if len(paths) > 1 else []:
                    try:  # a batch that failed is composed again a song at a time: only its bad songs are listed
                        batch([path], i)
                    except SONG_FAILURES as alone:
                        result.failed.append((path, describe_error(alone)))
            if bar:
                bar.update(task, completed=i + len(paths))
    return result


#: what a song that cannot be composed raises (``--keep-going`` lists it and carries on)
SONG_FAILURES = (DanceError, OSError, ValueError)

#: the options that give each edit (else it comes from the recipe's compose:)
EDIT_OPTIONS = {"keyframes": "--keyframe", "keep_parts": "--keep", "face": "--face", "max_turn": "--max-turn",
                "loop": "--loop", "from_motion": "--from", "regenerate": "--regenerate"}


def _option(options: ComposeOptions, name: str, flag: str) -> str:
    """The option a setting came from, or its recipe field (for one-line errors)."""
    return flag if options.given(name) else f"compose.{name}"


def _need_beat_tracker(recipe: Recipe, registry, where: str) -> None:
    """Markers hold the song's beats: without a registered beat tracker, one line before any work."""
    from dance_core.data.beat_tracking import beat_tracker

    if beat_tracker(registry) is None:
        raise RecipeError(f"{where}: the song's beats need a beat tracker (pip install dance-audio); none is "
                          "installed")
