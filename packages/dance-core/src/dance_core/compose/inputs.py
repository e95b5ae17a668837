"""What one composition reads and writes, resolved once from a recipe and the caller's typed options.

``dance compose`` and :func:`dance_core.compose.compose_songs` (and ``dance_core.api.compose``) both
call :func:`resolve_inputs`: the options a caller gives (:class:`ComposeOptions`, each over the
recipe's ``compose:`` section) are applied to the recipe, the songs (files, folders listed), the
checkpoint and the seed motion are found, relative paths from the recipe resolved against its folder.
The CLI checks the result before any work; composition reads it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from dance_core.errors import DataError, RecipeError
from dance_core.recipe.schema import ComposeSpec, Recipe, TextSpec
from dance_core.registry import Registry, get_registry
from dance_core.shards import Shard

#: the options that override a field of the recipe's ``compose:`` section
SETTINGS = ("samples", "seconds", "start", "temperature", "seed_motion", "texts", "formats", "markers", "rig",
            "rig_map", "output_fps", "units", "up", "keyframes", "keep_parts", "face", "max_turn", "loop",
            "from_motion", "regenerate")


@dataclass(frozen=True)
class ComposeOptions:
    """A caller's choices for one composition; ``None`` (or empty) keeps the recipe's ``compose:`` value.

    ``music``: song files or folders of them; ``texts``: ``TextSpec``s or their text form
    (``"20-30: a person jumps"``); ``overwrite=False`` skips a song whose output files all exist;
    ``shard``: compose only this part of the songs; ``quiet``: no progress bar or notes; ``keep_going``: a song
    that fails (unreadable, an implausible dance) is listed in ``Composed.failed`` and the others are written.
    """

    music: Sequence[str | Path] | None = None
    checkpoint: str | Path | None = None
    out_dir: str | Path | None = None
    samples: int | None = None
    seconds: float | None = None
    start: float | None = None
    temperature: float | None = None
    seed_motion: str | Path | None = None
    texts: Sequence[TextSpec | str] | None = None
    formats: Sequence[str] | None = None
    markers: bool | None = None
    rig: str | Path | None = None
    rig_map: str | Path | None = None
    output_fps: float | None = None
    units: str | None = None
    up: str | None = None
    keyframes: Sequence[str] | None = None
    keep_parts: Mapping[str, str | Path] | None = None
    face: str | None = None
    max_turn: float | None = None
    loop: bool | None = None
    from_motion: str | Path | None = None
    regenerate: Sequence[str] | None = None
    overwrite: bool = True
    shard: Shard | None = None
    quiet: bool = False
    keep_going: bool = False

    def given(self, name: str) -> bool:
        """True when the caller gave ``name`` (else the recipe's value holds)."""
        value = getattr(self, name)
        return bool(value) if name in ("music", "checkpoint", "out_dir") else value is not None

    def apply(self, recipe: Recipe) -> Recipe:
        """The recipe with the given settings in its ``compose:`` section, validated as the recipe's
        own (a bad value is one ``RecipeError`` line naming the option)."""
        updates = {name: getattr(self, name) for name in SETTINGS if self.given(name)}
        if not updates:
            return recipe
        if "texts" in updates:
            updates["texts"] = [t if isinstance(t, TextSpec) else TextSpec.parse(t) for t in updates["texts"]]
        if "formats" in updates:
            updates["formats"] = list(updates["formats"])
        for name in ("seed_motion", "rig", "rig_map", "from_motion"):
            if name in updates:
                updates[name] = str(updates[name])
        for name in ("keyframes", "regenerate"):
            if name in updates:
                updates[name] = [str(v) for v in updates[name]]
        if "keep_parts" in updates:
            updates["keep_parts"] = {str(k): str(v) for k, v in updates["keep_parts"].items()}
        try:
            spec = ComposeSpec.model_validate({**recipe.compose.model_dump(), **updates})
        except ValidationError as exc:
            error = exc.errors()[0]
            where = ".".join(str(part) for part in error["loc"])
            raise RecipeError(f"compose options: {where}: {error['msg']}") from None
        return recipe.model_copy(update={"compose": spec})


@dataclass(frozen=True)
class MusicInput:
    """A song or a folder of songs as given (a recipe's path resolved against its folder), with the
    audio files it stands for: the song itself, or the folder's audio files (:func:`audio_files`)."""

    path: str
    folder: bool
    files: tuple[str, ...]
    #: the suffixes the audio readers accept (named when a folder holds none of them)
    accepted: tuple[str, ...] = ()

    def songs(self, option: str | None = None) -> list[str]:
        """The song files; a folder without any is one ``DataError`` line naming ``option``."""
        if self.folder and not self.files:
            raise DataError(_no_audio_files(self.path, self.accepted, option))
        return list(self.files)


@dataclass(frozen=True)
class ComposeInputs:
    """One composition, resolved: the recipe with the options applied, the songs as given, the
    checkpoint, the seed motion as it will be read (``None``, ``rest`` or a file), the output folder, and
    the rig and its map as they will be read (files as given, else beside the recipe)."""

    recipe: Recipe
    options: ComposeOptions
    music: tuple[MusicInput, ...]
    checkpoint: str | None
    seed_motion: str | None
    out_dir: str
    rig: str | None = None
    rig_map: str | None = None

    def songs(self) -> list[str]:
        """Every song file in order, folders expanded (:meth:`MusicInput.songs`)."""
        return [song for music in self.music for song in music.songs()]


def resolve_inputs(
    recipe: Recipe, options: ComposeOptions | None = None, registry: Registry | None = None
) -> ComposeInputs:
    """Apply ``options`` to the recipe and find what the composition reads and writes (nothing is
    checked here: the caller checks or reads the result)."""
    options = options or ComposeOptions()
    registry = registry or get_registry()
    recipe = options.apply(recipe)
    c = recipe.compose
    paths = [str(m) for m in options.music] if options.given("music") else [recipe.resolve_path(m) for m in c.music]
    given = options.checkpoint if options.given("checkpoint") else None
    checkpoint = str(given) if given else (recipe.resolve_path(c.checkpoint) if c.checkpoint else None)
    out_dir = str(options.out_dir) if options.given("out_dir") else c.out_dir
    music = tuple(_music_input(path, registry) for path in paths)
    return ComposeInputs(recipe, options, music, checkpoint, beside_recipe(c.seed_motion, recipe), out_dir,
                         beside_recipe(c.rig, recipe), beside_recipe(c.rig_map, recipe))


def _music_input(path: str, registry: Registry) -> MusicInput:
    if not Path(path).is_dir():
        return MusicInput(path, False, (path,))
    accepted = tuple(sorted(registry.suffixes("audio-reader")))
    return MusicInput(path, True, tuple(_listing(path, accepted)), accepted)


def _listing(folder: str | Path, accepted: Sequence[str]) -> list[str]:
    return sorted(
        str(p) for p in Path(folder).iterdir()
        if p.is_file() and not p.name.startswith(".") and p.suffix.lower() in accepted
    )


def _no_audio_files(folder: str | Path, accepted: Sequence[str], option: str | None) -> str:
    label = f"{option} {folder}" if option else str(folder)
    return f"{label}: no audio files in this folder (suffixes read: {', '.join(sorted(accepted))})"


def audio_files(folder: str | Path, registry: Registry, option: str | None = None) -> list[str]:
    """The audio files directly in ``folder`` that a registered audio reader accepts, sorted by name
    (hidden files, such as our own temporary files, are left out); none is one line naming ``option``."""
    accepted = set(registry.suffixes("audio-reader"))
    found = _listing(folder, accepted)
    if not found:
        raise DataError(_no_audio_files(folder, accepted, option))
    return found


def expand_music(paths: list[str], registry: Registry) -> list[str]:
    """Songs from files and folders: a folder stands for its audio files (:func:`audio_files`)."""
    out: list[str] = []
    for path in paths:
        out.extend(audio_files(path, registry) if Path(path).is_dir() else [str(path)])
    return out


def reads_text(recipe: Recipe, registry: Registry) -> bool:
    """True when one of the recipe's feature extractors reads text (registered with ``reads=("text",)``)."""
    return any("text" in registry.get("feature", spec.plugin).info.get("reads", ("audio",))
               for specs in recipe.features.values() for spec in specs)


def beside_recipe(spec: str | None, recipe: Recipe) -> str | None:
    """A seed file as given when it exists, else relative to the recipe (recipes ship seeds)."""
    if spec in (None, "rest") or Path(spec).exists():
        return spec
    beside = recipe.resolve_path(spec)
    return beside if Path(beside).exists() else spec
