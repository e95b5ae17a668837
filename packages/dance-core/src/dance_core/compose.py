"""The composition loop behind ``dance compose``: music in, motion files out."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import torch

from dance_core.atomic import OutputSet, sweep_stale_temps
from dance_core.checkpoint import Checkpoint, check_matches, load_checkpoint, load_weights
from dance_core.contexts import DEFAULT_FORMATS, FormatOptions
from dance_core.data.features import FeatureStack, load_audio
from dance_core.data.files import read_motion_file
from dance_core.data.motion_info import MotionInfo
from dance_core.errors import DanceError, DataError, RecipeError
from dance_core.media import TextSpan, frame_count
from dance_core.model import ComposedModel, build_model
from dance_core.progress import progress_bar
from dance_core.protocols import MotionData
from dance_core.recipe.schema import Recipe, TextSpec
from dance_core.registry import Registry, get_registry
from dance_core.row_generators import RowGenerators, supports_row_generators
from dance_core.runtime import generation_threads, pick_device
from dance_core.shards import Shard


@dataclass
class Song:
    """One song's name, features and frame count."""

    name: str
    streams: dict[str, np.ndarray]
    n_frames: int
    path: str = ""
    texts: tuple[TextSpan, ...] = ()


def seed_motion(
    spec: str | None, ckpt: Checkpoint, frames: int, registry: Registry, formats: FormatOptions = DEFAULT_FORMATS
) -> np.ndarray:
    """Normalized seed ``(frames, D)``: the mean pose for ``rest``/None, else a motion file (read with its
    format's options in ``formats``)."""
    dim = ckpt.motion.dim
    if spec in (None, "rest"):
        return np.zeros((frames, dim), np.float32)
    motion = ckpt.motion.encode(read_motion_file(spec, registry, formats=formats), registry)
    if motion.values.shape[1] != dim:
        raise DataError(f"{spec}: seed motion has {motion.values.shape[1]} channels, the model {dim}")
    if abs(motion.fps - ckpt.motion.fps) > 1e-6:
        raise DataError(f"{spec}: seed motion is at {motion.fps:g} fps, the model at {ckpt.motion.fps:g}")
    values = ckpt.stats.motion.apply(motion.values)
    if len(values) < frames:
        values = np.concatenate([np.repeat(values[:1], frames - len(values), axis=0), values])
    return values[len(values) - frames :]


def reads_text(recipe: Recipe, registry: Registry) -> bool:
    """True when one of the recipe's feature extractors reads text (registered with ``reads=("text",)``)."""
    return any("text" in registry.get("feature", spec.plugin).info.get("reads", ("audio",))
               for specs in recipe.features.values() for spec in specs)


def song_texts(texts: list[TextSpec], duration: float, where: str) -> tuple[TextSpan, ...]:
    """The recipe's text spans on one song (an open end is the song's end); a span past the song is an error."""
    spans = []
    for i, t in enumerate(texts):
        start, end = t.start or 0.0, min(t.end or duration, duration)
        if start >= duration:
            raise DataError(
                f"{where}: compose.texts.{i}: starts at {start:g} s, after the song's end ({duration:.1f} s)"
            )
        spans.append(TextSpan(t.text, start, end))
    return tuple(spans)


def load_song(
    path: str, stack: FeatureStack, ckpt: Checkpoint, seconds: float | None, registry: Registry,
    texts: list[TextSpec] = (),
) -> Song:
    """Features of one song (and its text spans), standardized with the checkpoint's statistics."""
    audio = load_audio(path, registry, stack.formats)
    n_audio = audio.n_frames(stack.fps)
    spans = song_texts(list(texts), n_audio / stack.fps, path)
    raw = stack.extract(n_audio, audio, spans)
    n = frame_count(seconds, stack.fps) if seconds else n_audio
    streams = {}
    for name, values in raw.items():
        if name not in ckpt.stats.streams:
            raise DataError(f"{path}: feature stream {name!r} has no statistics in {ckpt.path}")
        values = ckpt.stats.streams[name].apply(values)
        if n > len(values):
            values = np.concatenate([values, np.repeat(values[-1:], n - len(values), axis=0)])
        streams[name] = values[:n]
    return Song(Path(path).stem, streams, n, str(path), spans)


def load_model(
    recipe: Recipe, checkpoint: str | Path, device: torch.device
) -> tuple[ComposedModel, Checkpoint, FeatureStack]:
    """Build the recipe's model and load a checkpoint that matches it."""
    ckpt = load_checkpoint(checkpoint)
    check_matches(ckpt, recipe)
    stack = FeatureStack(recipe)
    model = build_model(recipe, ckpt.motion.dim, stack.dims())
    load_weights(model, ckpt)
    return model.to(device).eval(), ckpt, stack


@dataclass
class Composed:
    """What one composition call did: files written, songs written and skipped, frames generated."""

    written: list[Path] = field(default_factory=list)
    songs: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    shard: Shard | None = None


def audio_files(folder: str | Path, registry: Registry, option: str | None = None) -> list[str]:
    """The audio files directly in ``folder`` that a registered audio reader accepts, sorted by name
    (hidden files, such as our own temporary files, are left out); none is one line naming ``option``."""
    accepted = set(registry.suffixes("audio-reader"))
    found = sorted(
        str(p) for p in Path(folder).iterdir()
        if p.is_file() and not p.name.startswith(".") and p.suffix.lower() in accepted
    )
    if not found:
        label = f"{option} {folder}" if option else str(folder)
        raise DataError(f"{label}: no audio files in this folder (suffixes read: {', '.join(sorted(accepted))})")
    return found


def expand_music(paths: list[str], registry: Registry) -> list[str]:
    """Songs from files and folders: a folder stands for its audio files (:func:`audio_files`)."""
    out: list[str] = []
    for path in paths:
        out.extend(audio_files(path, registry) if Path(path).is_dir() else [str(path)])
    return out


def output_targets(out: Path, stems: list[str], formats: list, texts: bool) -> list[Path]:
    """Every file one song's dances are written to (its output set), in write order."""
    targets = []
    for stem in stems:
        targets.extend(out / f"{stem}{_suffix(entry)}" for entry, _ in formats)
        if texts:
            targets.append(out / f"{stem}.texts")
    return targets


def complete(targets: list[Path]) -> bool:
    """True when every file of a song's output set exists and is not empty. A set is committed by
    renaming its temporary files in one pass with signals held, so only a kill inside that pass (or
    files removed by hand) leaves part of a set, and a part is never taken as complete."""
    return all(t.is_file() and t.stat().st_size > 0 for t in targets)


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
    c = recipe.compose
    registry = get_registry()
    checkpoint = checkpoint or (recipe.resolve_path(c.checkpoint) if c.checkpoint else None)
    if checkpoint is None:
        raise RecipeError(f"{recipe.origin}: compose.checkpoint: no model given (or pass --checkpoint)")
    songs_in = expand_music(music or [recipe.resolve_path(m) for m in c.music], registry)
    if not songs_in:
        raise RecipeError(f"{recipe.origin}: compose.music: no song given (or pass --music)")
    if c.texts and not reads_text(recipe, registry):
        features = ", ".join(s.plugin for specs in recipe.features.values() for s in specs)
        raise RecipeError(f"{recipe.origin}: compose.texts: this model reads no text (features: {features}); "
                          "drop --text or use a recipe with a text feature such as tm2d-small")
    formats = [(entry, recipe.format_options.build(entry))
               for entry in (registry.find("motion-format", f) for f in c.formats)]
    stems = dict(zip(songs_in, _output_stems(songs_in, c.samples), strict=True))  # every song's, before sharding
    mine = shard.select(songs_in) if shard else songs_in
    out = Path(out_dir or c.out_dir)
    result = Composed(songs=list(mine), shard=shard)
    todo = []
    for path in mine:
        targets = output_targets(out, stems[path], formats, bool(c.texts))
        if not overwrite and complete(targets):
            sweep_stale_temps(out, [t.name for t in targets])  # what a killed run left beside a whole set
            result.skipped.append(path)
        else:
            todo.append(path)
    if not todo:
        return result
    device = pick_device(c.device, c.threads)
    model, ckpt, stack = load_model(recipe, checkpoint, device)
    start = model.start_frames()
    seed_values = seed_motion(_beside_recipe(c.seed_motion, recipe), ckpt, start, registry, recipe.format_options)
    seed = torch.from_numpy(seed_values)
    per_batch = c.batch_songs
    note = batching_note(model) if per_batch > 1 and len(todo) > 1 else None
    if note:
        per_batch = 1
        if not quiet:
            print(f"dance: note: compose.batch_songs={c.batch_songs}: {note}; composing one song at a time",
                  file=sys.stderr)
    with progress_bar(quiet) as bar:
        task = bar.add_task("compose", total=len(todo), info=f"{len(todo)} song(s) × {c.samples}") if bar else None
        for i in range(0, len(todo), per_batch):
            paths = todo[i : i + per_batch]
            songs = [load_song(path, stack, ckpt, c.seconds, registry, c.texts) for path in paths]
            n, k = max(song.n_frames for song in songs), len(songs)
            progress = (lambda t, i=i, n=n, k=k: bar.update(task, completed=i + k * t / n)) if bar else None
            if bar:
                names = ", ".join(song.name for song in songs)
                bar.update(task, info=f"{names} ({i + len(songs)}/{len(todo)}) × {c.samples}")
            if len(songs) == 1:
                motions = [generate_song(model, songs[0], seed, recipe, device, progress)]
            else:
                motions = generate_songs(model, songs, seed, recipe, device, progress)
            for path, song, motion in zip(paths, songs, motions, strict=True):
                result.written.extend(write_song(song, motion, stems[path], out, formats, ckpt, recipe, registry))
                result.frames += c.samples * song.n_frames
                result.seconds += c.samples * song.n_frames / recipe.fps
            if bar:
                bar.update(task, completed=i + len(songs))
    return result


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


def write_song(
    song: Song, motion: np.ndarray, stems: list[str], out: Path, formats: list, ckpt: Checkpoint,
    recipe: Recipe, registry: Registry,
) -> list[Path]:
    """Decode, ground and write one song's dances ``(samples, frames, D)`` as one output set (every
    file or none); returns the motion files written."""
    c = recipe.compose
    with OutputSet() as files:
        for k, stem in enumerate(stems):
            values = ckpt.stats.motion.invert(motion[k, : song.n_frames])
            data = ckpt.motion.decode(values, recipe.fps, registry)
            if c.ground and data.skeleton_motion is not None:
                data = grounded(data, ckpt.motion, registry)
            data.meta["audio_path"] = song.path
            for entry, fmt in formats:
                fmt.write(data, str(files.path(out / f"{stem}{_suffix(entry)}")))
            if song.texts:  # the spans beside the dance, for dance evaluate (MPD at text starts)
                lines = "".join(f"{t.start:.4f}\t{t.end:.4f}\t{' '.join(t.text.split())}\n" for t in song.texts)
                files.path(out / f"{stem}.texts").write_text(lines, encoding="utf-8")
        return [p for p in files.targets() if p.suffix != ".texts"]


def generate_song(
    model: ComposedModel, song: Song, seed: torch.Tensor, recipe: Recipe, device: torch.device,
    progress=None,
) -> np.ndarray:
    """``compose.samples`` dances of one song, ``(samples, frames, D)`` normalized.

    Each song is generated on its own, its samples as one batch, with the random generator seeded
    from the recipe's seed: a song's dance does not depend on the other songs in the call.
    """
    c = recipe.compose
    streams = {
        name: torch.from_numpy(np.ascontiguousarray(np.repeat(values[None], c.samples, axis=0))).to(device)
        for name, values in song.streams.items()
    }
    generation_threads(model, c.samples, device, c.threads)
    generator = torch.Generator(device=device).manual_seed(recipe.seed)
    torch.manual_seed(recipe.seed)
    motion = model.generate(
        streams,
        song.n_frames,
        seed.unsqueeze(0).expand(c.samples, -1, -1).to(device),
        temperature=c.temperature,
        keep=c.keep,
        generator=generator,
        progress=progress,
    )
    motion = motion.float().cpu().numpy()
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
    longest = max(song.n_frames for song in songs)
    names = list(songs[0].streams)
    streams = {}
    for name in names:
        rows = []
        for song in songs:
            values = song.streams[name]
            if len(values) < longest:
                values = np.concatenate([values, np.repeat(values[-1:], longest - len(values), axis=0)])
            rows.append(np.repeat(values[None], c.samples, axis=0))
        streams[name] = torch.from_numpy(np.ascontiguousarray(np.concatenate(rows))).to(device)
    batch = len(songs) * c.samples
    generation_threads(model, batch, device, c.threads)
    generator = RowGenerators.same_seed(recipe.seed, len(songs), c.samples, device)
    torch.manual_seed(recipe.seed)
    motion = model.generate(
        streams,
        longest,
        seed.unsqueeze(0).expand(batch, -1, -1).to(device),
        temperature=c.temperature,
        keep=c.keep,
        generator=generator,
        progress=progress,
    )
    motion = motion.float().cpu().numpy()
    out = []
    for k, song in enumerate(songs):
        part = motion[k * c.samples : (k + 1) * c.samples, : song.n_frames]
        if not np.all(np.isfinite(part)):
            raise DanceError(f"{song.path or song.name}: the model produced NaN or inf motion; nothing was written "
                             "for it")
        out.append(part)
    return out


def _suffix(entry) -> str:
    return (entry.suffixes or ("." + entry.name,))[0]


def _output_stems(paths: list[str], samples: int) -> list[list[str]]:
    """Per song, the file stems of its samples; two songs that would write the same files are an error."""
    seen: dict[str, str] = {}
    stems = []
    for path in paths:
        name = Path(path).stem
        if name in seen:
            raise DataError(f"{path}: another song ({seen[name]}) has the same name; their dances would "
                            "overwrite each other (rename one)")
        seen[name] = str(path)
        stems.append([name] if samples == 1 else [f"{name}-{k}" for k in range(samples)])
    return stems


def grounded(data: MotionData, info: MotionInfo, registry: Registry) -> MotionData:
    """A decoded skeletal dance on the floor with its feet pinned in contact (``compose.ground``),
    its frame array encoded again from the grounded motion."""
    from dance_core.motion.grounding import ground

    motion, report = ground(data.skeleton_motion)
    data.meta["grounding"] = report.summary()
    if report.skipped:
        return data
    rep = info.build_representation(registry)
    return replace(data, values=rep.encode(motion).astype(data.values.dtype), skeleton_motion=motion)


def _beside_recipe(spec: str | None, recipe: Recipe) -> str | None:
    """A seed file as given when it exists, else relative to the recipe (recipes ship seeds)."""
    if spec in (None, "rest") or Path(spec).exists():
        return spec
    beside = recipe.resolve_path(spec)
    return beside if Path(beside).exists() else spec
