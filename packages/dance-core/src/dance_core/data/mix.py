"""The ``mix`` dataset: the clips of several datasets in one training set.

TM2D trains on two disjoint corpora at once (music-dance pairs and text-motion clips); a recipe says so
with ``{plugin: mix, datasets: [{plugin: synthetic-dance, songs: 8, keep_texts: false},
{plugin: synthetic-moves, clips: 200}]}``. Every part is validated by its own plugin's config when the
recipe loads (a bad option is an error at ``data.dataset.datasets.N.<field>``) and built through the
registry with the mix's own ``DatasetContext``. Clip names get the part's index as a prefix
(``0-synth-0000``, ``1-move-0003-clap``) so they stay unique; ``keep_texts: false`` drops a part's texts
(a music-dance corpus that must carry no text, like ``synthetic-dance`` whose moves are labelled).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from dance_core.contexts import DEFAULT_FORMATS, DatasetContext, FormatOptions
from dance_core.data.sources import ClipSource


class Mix:
    """The ``mix`` dataset: its parts, built."""

    def __init__(self, config: Any, context: DatasetContext):
        from dance_core.registry import get_registry

        registry = get_registry()
        self.config = config
        self.parts = [(part, registry.create("dataset", part.plugin, part.options(), context))
                      for part in config.datasets]

    def clips(self) -> list[ClipSource]:
        """Every part's clips in order, renamed ``<part index>-<name>``, with ``meta["part"]`` and
        ``meta["dataset"]`` naming where they came from."""
        out = []
        for i, (part, dataset) in enumerate(self.parts):
            for clip in dataset.clips():
                meta = {**clip.meta, "part": i, "dataset": part.plugin}
                texts = clip.texts if part.keep_texts else ()
                out.append(replace(clip, name=f"{i}-{clip.name}", texts=texts, meta=meta))
        return out


def build(
    config: Any, *, fps: float, seed: int = 0, root: str = ".", formats: FormatOptions = DEFAULT_FORMATS, **_: Any
) -> Mix:
    """Build the ``mix`` dataset (each part with the same context)."""
    return Mix(config, DatasetContext(fps=fps, seed=seed, root=root, formats=formats))
