"""Rewrite one marked section of benchmarks/README.md (shared by the benchmark scripts)."""

from __future__ import annotations

from pathlib import Path

README = Path(__file__).resolve().parent / "README.md"


def write_section(name: str, text: str, readme: Path = README) -> None:
    """Replace what stands between ``<!-- name:start -->`` and ``<!-- name:end -->``, atomically."""
    from dance_core.atomic import write_text

    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    current = readme.read_text(encoding="utf-8")
    if start not in current or end not in current:
        raise SystemExit(f"{readme}: no {start} ... {end} markers")
    head, rest = current.split(start, 1)
    write_text(readme, head + start + "\n" + text.rstrip("\n") + "\n" + end + rest.split(end, 1)[1])
