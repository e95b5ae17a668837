"""Reading motion files through the registered formats, and listing audio/motion pairs in folders."""

from __future__ import annotations

from pathlib import Path

from dance_core.errors import DataError
from dance_core.media import TextSpan
from dance_core.protocols import MotionData
from dance_core.registry import Registry

PREVIEWS = {".gif", ".mp4", ".html"}


def motion_suffixes(registry: Registry) -> dict[str, str]:
    """Readable motion suffixes and the format registered for each (previews are write-only)."""
    out = {}
    for e in registry.entries("motion-format"):
        for s in e.info.get("suffixes", ()):
            if s not in PREVIEWS:
                out.setdefault(s, e.name)
    return out


def audio_suffixes(registry: Registry) -> set[str]:
    """Suffixes some registered audio reader can read."""
    return {s for e in registry.entries("audio-reader") for s in e.info.get("suffixes", ())}


def read_motion_file(path: str | Path, registry: Registry, fmt: str | None = None) -> MotionData:
    """Read a motion file with the format registered for its suffix (or the named format)."""
    path = Path(path)
    name = fmt or motion_suffixes(registry).get(path.suffix.lower())
    if name is None:
        known = ", ".join(sorted(motion_suffixes(registry)))
        raise DataError(f"{path}: no motion format reads {path.suffix or 'files without a suffix'!r} ({known})")
    return registry.get("motion-format", name).build().read(str(path))


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
