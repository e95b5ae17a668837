"""Typed build contexts: what core hands a component's builder besides its validated config.

A builder registered for a kind is called as ``build(config, **fields(context))``: the fields of that
kind's context arrive as keyword arguments, so a builder takes the ones it needs and ``**_`` for the
rest. Which kind receives which context is its row in ``dance_core.kinds``; kinds with ``NoContext``
are built from their config alone.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from dance_core.protocols import Window


@dataclass(frozen=True)
class ConditionerContext:
    """A conditioner embeds one feature stream: its name and width."""

    input: str
    in_dim: int


@dataclass(frozen=True)
class EncoderContext:
    """An encoder sees past motion of ``motion_dim`` channels and conditioning streams of these widths
    (a stream's conditioner output width when it has one, else the raw feature width)."""

    motion_dim: int
    cond_dims: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class HeadContext:
    """A head turns the encoder's latent into ``motion_dim`` channels per frame; ``cond_dims`` are the
    conditioned streams' widths (for a sequence head reading a stream itself, e.g. TM2D's text)."""

    motion_dim: int
    latent_dim: int
    latent_tokens: int | None
    window: Window
    cond_dims: Mapping[str, int] | None = None  # None: not known (a head checked on its own)


@dataclass(frozen=True)
class FormatOptions:
    """A recipe's ``formats:``: the validated options of motion formats and audio readers, by kind and
    name. ``build(entry)`` builds a format or reader with them (with its defaults when none are given)."""

    configs: Mapping[tuple[str, str], Any] = field(default_factory=dict)

    def config(self, kind: str, name: str) -> Any:
        """The options given for one format or reader (``None``: its defaults)."""
        return self.configs.get((kind, name))

    def build(self, entry: Any) -> Any:
        """Build a registry ``Entry`` (a motion format or audio reader) with the options given for it."""
        return entry.build(self.config(entry.kind, entry.name))


#: no ``formats:`` options: every format and reader built with its defaults
DEFAULT_FORMATS = FormatOptions()


@dataclass(frozen=True)
class DatasetContext:
    """A dataset produces clips at the recipe's ``fps`` and ``seed``; relative paths are from ``root``;
    motion and audio files it picks by suffix are read with the recipe's ``formats`` options."""

    fps: float
    seed: int = 0
    root: str = "."
    formats: FormatOptions = DEFAULT_FORMATS


@dataclass(frozen=True)
class NoContext:
    """Kinds built from their config alone (features, readers, formats, representations, metrics...)."""


def as_kwargs(context: Any) -> dict[str, Any]:
    """The keyword arguments a builder receives for a context object (``None``: none)."""
    if context is None:
        return {}
    return {f.name: getattr(context, f.name) for f in fields(context)}
