"""Reading motion files through the registered formats, and listing audio/motion pairs in folders."""

from __future__ import annotations

from pathlib import Path

from dance_core.contexts import DEFAULT_FORMATS, FormatOptions
from dance_core.errors import DataError
from dance_core.media import TextSpan
from dance_core.protocols import MotionData
from dance_core.registry import Registry


def motion_suffixes(registry: Registry) -> dict[str, str]:
    """Readable motion suffixes and the format chosen for each (previews are write-only)."""
    return registry.suffixes("motion-format")


def audio_suffixes(registry: Registry) -> set[str]:
    """Suffixes some registered audio reader can read."""
    return set(registry.suffixes("audio-reader"))


def read_motion_file(
    path: str | Path, registry: Registry, fmt: str | None = None, formats: FormatOptions = DEFAULT_FORMATS
) -> MotionData:
    """Read a motion file with the format chosen for its suffix (highest priority), or the named format,
    built with its options in ``formats`` (a recipe's ``formats:``)."""
    path = Path(path)
    entry = registry.get("motion-format", fmt) if fmt else registry.for_suffix("motion-format", path.suffix)
    if entry is None:
        known = ", ".join(motion_suffixes(registry))
        raise DataError(f"{path}: no motion format reads {path.suffix or 'files without a suffix'!r} ({known})")
    data = formats.build(entry).read(str(path))
    data.meta.setdefault("path", str(path))  # every format: errors about this motion can name its file
    return data


def motion_files(folder: Path, registry: Registry, only: list[str] | None = None) -> list[Path]:
    """Every file in ``folder`` whose suffix a registered motion format reads (or one of ``only``); hidden
    files (``.NAME``: compose's output manifests, temporary files of writes in progress) are not motion."""
    if not folder.is_dir():
        raise DataError(f"{folder}: not a folder of motion files")
    suffixes = set(motion_suffixes(registry))
    if only:
        wanted = {s.lower() if s.startswith(".") else f".{s.lower()}" for s in only}
        unknown = sorted(wanted - suffixes)
        if unknown:
            raise DataError(f"no motion format reads {', '.join(unknown)} (readable: {', '.join(sorted(suffixes))})")
        suffixes = wanted
    files = sorted(p for p in folder.iterdir()
                   if p.is_file() and not p.name.startswith(".") and p.suffix.lower() in suffixes)
    if not files:
        raise DataError(f"{folder}: no motion files (readable: {', '.join(sorted(suffixes))})")
    return files


def read_texts(path: Path) -> tuple[TextSpan, ...]:
    """Timed text from a ``.texts`` file: ``start<TAB>end<TAB>sentence`` per line (``#`` comments)."""
    spans = []
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split("\t")
        try:
            spans.append(TextSpan(parts[2].strip(), float(parts[0]), float(parts[1])))
        except (IndexError, ValueError):
            raise DataError(f"{path}:{i}: expected start<TAB>end<TAB>sentence") from None
    return tuple(spans)


def pair_folder(folder: Path, registry: Registry) -> list[tuple[str, Path, Path]]:
    """``(name, audio, motion)`` for every motion file in ``folder``; a motion with no audio of the same
    name, or two motion files of one name, is an error."""
    if not folder.is_dir():
        raise DataError(f"{folder}: dataset folder not found")
    motions = motion_suffixes(registry)
    audios = audio_suffixes(registry)
    by_stem: dict[str, dict[str, list[Path]]] = {}
    for p in sorted(folder.iterdir()):
        kind = "motion" if p.suffix.lower() in motions else "audio" if p.suffix.lower() in audios else None
        if kind and p.is_file():
            by_stem.setdefault(p.stem, {"motion": [], "audio": []})[kind].append(p)
    pairs = []
    for stem, found in by_stem.items():
        if not found["motion"]:
            continue
        if len(found["motion"]) > 1:
            raise DataError(f"{folder}: {stem}: several motion files ({', '.join(p.name for p in found['motion'])})")
        if not found["audio"]:
            raise DataError(f"{found['motion'][0]}: no audio partner ({stem} with one of {', '.join(sorted(audios))})")
        pairs.append((stem, found["audio"][0], found["motion"][0]))
    if not pairs:
        raise DataError(f"{folder}: no motion files ({', '.join(sorted(motions))}) found")
    return pairs
