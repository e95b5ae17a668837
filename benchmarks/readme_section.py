"""Rewrite one marked section of benchmarks/README.md (shared by the benchmark scripts)."""

from __future__ import annotations

from pathlib import Path

README = Path(__file__).resolve().parent / "README.md"


def write_section(name: str, text: str, readme: Path = README) -> None:
    """Replace what stands between ``<!-- name:start -->`` and ``<!-- name:end -->``, atomically."""
    from dance_core import write_text

    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    current = readme.read_text(encoding="utf-8")
    if start not in current or end not in current:
        raise SystemExit(f"{readme}: no {start} ... {end} markers")
    head, rest = current.split(start, 1)
    write_text(readme, head + start + "\n" + text.rstrip("\n") + "\n" + end + rest.split(end, 1)[1])


def verdict_line(opening: str, readme: Path = README, skip: str = "claims") -> str | None:
    """The README's bullet that starts with ``opening`` (with its indented continuation lines), or None.
    Lines between the ``skip`` section's markers (where the claims table quotes it) are not searched."""
    lines = readme.read_text(encoding="utf-8").splitlines()
    inside, searched = False, []
    for i, line in enumerate(lines):
        if line.strip() == f"<!-- {skip}:start -->":
            inside = True
        elif line.strip() == f"<!-- {skip}:end -->":
            inside = False
        elif not inside:
            searched.append(i)
    start = next((i for i in searched if lines[i].startswith(opening)), None)
    if start is None:
        return None
    end = next((i for i in range(start + 1, len(lines)) if not lines[i].startswith("  ")), len(lines))
    return "\n".join(lines[start:end])
