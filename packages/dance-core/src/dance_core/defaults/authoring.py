"""Core's tools for plugin authors: ``dance plugin new`` writes a plugin package to start from."""

from __future__ import annotations

from dance_core.hookspecs import hookimpl


@hookimpl
def register_commands(subparsers):
    """``dance plugin new NAME --kind KIND``."""
    from dance_core.cli import plugin_new

    plugin_new.add_parser(subparsers)
