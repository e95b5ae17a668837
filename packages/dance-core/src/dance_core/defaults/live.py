"""``dance live``: core's command for dancing to music as it plays (:mod:`dance_core.live`)."""

from __future__ import annotations

from dance_core.hookspecs import hookimpl


@hookimpl
def register_commands(subparsers):
    """``dance live RECIPE --input SOURCE --output SINK``."""
    from dance_core.cli import live

    live.add_parser(subparsers)
