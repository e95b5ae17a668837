"""Per-row random streams for batches that hold several songs (``compose.batch_songs``).

A batch of one song's samples draws its noise from one ``torch.Generator``. When several songs share a
batch, each song's rows must draw what that song's own generator would draw alone, so that a song's
dance does not depend on its batch-mates' noise. :class:`RowGenerators` holds one generator per group
of consecutive rows; heads draw through :func:`draw_rows` instead of calling ``torch.randn(...,
generator=)`` themselves, and declare it with a class attribute ``row_generators = True`` on the head's
own class (:func:`supports_row_generators`; not inherited, since a subclass may draw differently). Core
composes songs together only for such heads.

``draw_rows(generator, batch, fn)`` with a plain generator (or None) is exactly ``fn(generator,
batch)``: one song's generation draws the same numbers, in the same order, as a direct call.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence

import torch


class RowGenerators:
    """One random generator per group of consecutive batch rows (one group per song).

    ``generators[i]`` drives rows ``sum(rows[:i]) .. sum(rows[:i+1])``. :meth:`same_seed` builds groups
    whose generators all start from one seed and draw in lock-step; they then stay equal, so one
    generator draws once per call and its draw is repeated for every group (the same numbers, one
    kernel launch instead of one per group)."""

    def __init__(self, generators: Sequence[torch.Generator], rows: int | Sequence[int], *, shared: bool = False):
        if not generators:
            raise ValueError("RowGenerators needs at least one generator")
        rows = [rows] * len(generators) if isinstance(rows, int) else list(rows)
        if len(rows) != len(generators) or any(n < 1 for n in rows):
            raise ValueError(f"RowGenerators: {len(generators)} generator(s) but rows {rows}")
        if shared and (len(set(rows)) != 1 or any(g is not generators[0] for g in generators)):
            raise ValueError("RowGenerators: shared groups need one generator and equal row counts")
        if not shared and len({id(g) for g in generators}) != len(generators):
            raise ValueError("RowGenerators: a generator given twice would draw for both groups in turn "
                             "(use RowGenerators.same_seed for groups that share a seed)")
        self.generators = list(generators)
        self.rows = rows
        self.shared = shared

    @classmethod
    def same_seed(cls, seed: int, groups: int, rows: int, device: torch.device | str = "cpu") -> RowGenerators:
        """``groups`` groups of ``rows`` rows, each drawing what ``torch.Generator(device).manual_seed(seed)``
        would draw alone for a batch of ``rows`` (compose seeds every song with the recipe's seed)."""
        g = torch.Generator(device=device).manual_seed(seed)
        return cls([g] * groups, rows, shared=True)

    @property
    def batch(self) -> int:
        """Rows in all."""
        return sum(self.rows)

    @property
    def device(self) -> torch.device:
        """The generators' device."""
        return self.generators[0].device

    def groups(self) -> Iterator[tuple[torch.Generator, int]]:
        """``(generator, rows)`` per group, in row order."""
        return zip(self.generators, self.rows, strict=True)

    def __repr__(self) -> str:
        kind = "shared seed" if self.shared else "own generators"
        return f"RowGenerators({len(self.rows)} groups of {self.rows} rows, {kind})"


def draw_rows(
    generator: torch.Generator | RowGenerators | None,
    batch: int,
    fn: Callable[[torch.Generator | None, int], torch.Tensor],
    dim: int = 0,
) -> torch.Tensor:
    """Random values for ``batch`` rows: ``fn(generator, n)`` returns a tensor with ``n`` rows along
    ``dim``. A plain generator (or None) is one call ``fn(generator, batch)``; :class:`RowGenerators`
    calls ``fn`` once per group with that group's generator and row count and joins the parts along
    ``dim``, so each group gets what its generator would give it alone (rejection loops included,
    when ``fn`` runs them)."""
    if not isinstance(generator, RowGenerators):
        return fn(generator, batch)
    if generator.batch != batch:
        raise ValueError(f"draw_rows: the generators cover {generator.batch} rows, the batch has {batch}")
    if generator.shared:
        part = fn(generator.generators[0], generator.rows[0])
        return torch.cat([part] * len(generator.rows), dim) if len(generator.rows) > 1 else part
    return torch.cat([fn(g, n) for g, n in generator.groups()], dim)


def supports_row_generators(head: object) -> bool:
    """True when the head's own class declares ``row_generators = True`` (a subclass that draws noise
    differently must not inherit its parent's declaration, so it declares it again)."""
    return bool(type(head).__dict__.get("row_generators", False))
