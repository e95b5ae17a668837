"""Splitting a song list between machines or job-array tasks that never talk to each other."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Shard:
    """Part ``index`` of ``count`` (1-based) of a song list: song ``k`` of the list sorted by path
    (0-based) belongs to part ``k mod count + 1``, so ``count`` machines or job-array tasks given the
    same songs share them without talking to each other."""

    index: int
    count: int

    @classmethod
    def parse(cls, text: str) -> Shard:
        """``"i/n"`` with ``1 <= i <= n``; anything else raises ``ValueError`` with the reason."""
        parts = str(text).strip().split("/")
        if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
            raise ValueError(f"expected I/N, part I of N counting from 1 (e.g. 1/4), got {text!r}")
        index, count = (int(p) for p in parts)
        if count < 1 or not 1 <= index <= count:
            raise ValueError(f"expected I/N with 1 <= I <= N, got {text!r}")
        return cls(index, count)

    def select(self, paths: list[str]) -> list[str]:
        """This part's songs, in path order."""
        ordered = sorted(paths, key=str)
        return [p for k, p in enumerate(ordered) if k % self.count == self.index - 1]

    def __str__(self) -> str:
        return f"{self.index}/{self.count}"
