"""The synthesizer: songs (drums, bass, chords) with known beats and sections, a beat-locked dancer on
``dance24`` with labelled moves, its choreography to any song, the ``synthetic-dance`` and
``synthetic-moves`` datasets and ``dance synth``; registered by core's ``synth`` default plugin
(``dance_core.defaults.synth``).

``__all__`` is what scripts may use (stable within a minor version, like ``dance_core``'s names), loaded
on first use: a synthetic song with its dancer (``make_clip``; real moves from ``takes_graph``), written as
files (``write_clip``, ``write_dataset``), a song alone (``synthesize``), the dancer's phrasings and a click track.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> the module that defines it (imported on first use)
_LAZY: dict[str, str] = {
    **dict.fromkeys(("make_clip", "write_clip", "write_dataset", "takes_graph"), "dance_core.synth.synthetic_dance"),
    "synthesize": "dance_core.synth.music",
    "PHRASINGS": "dance_core.synth.dancer",
    "click_track": "dance_core.data.synthetic_beats",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'dance_core.synth' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
