"""Core's synthesizer: the ``synthetic-dance`` and ``synthetic-moves`` datasets and ``dance synth``."""

from __future__ import annotations

from dance_core.hookspecs import hookimpl
from dance_core.synth import configs as sc

_S = "dance_core.synth"


@hookimpl
def register_datasets(register):
    """The synthetic dancer's datasets: to synthesized songs, and one move alone with its words."""
    register("synthetic-dance", sc.SyntheticDanceConfig, f"{_S}.synthetic_dance:build",
             "synthesized songs (drums, bass, chords) with a beat-locked dancer (dance24) and move labels")
    register("synthetic-moves", sc.SyntheticMovesConfig, f"{_S}.synthetic_moves:build",
             "text-motion clips: the synthetic dancer performing one move alone, described in words, no music")


@hookimpl
def register_commands(subparsers):
    """``dance synth`` (a click-track song, or a synthetic dance dataset)."""
    from dance_core.synth import command

    command.add_parser(subparsers)
