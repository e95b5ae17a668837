"""Core's previews: stick-figure GIF, MP4 and offline HTML player (write-only motion formats), and
``dance render``, ``dance retarget`` and ``dance convert``."""

from __future__ import annotations

from dance_core.formats import configs as fc
from dance_core.hookspecs import hookimpl


@hookimpl
def register_motion_formats(register):
    """Write-only preview formats (``write_only=True``: never chosen to read a file)."""
    for kind, what, build in (("gif", "animated GIF", "build_gif"), ("mp4", "MP4 video with the song", "build_mp4"),
                              ("html", "offline HTML player", "build")):
        register(kind, fc.PreviewFormatConfig, f"dance_core.render.preview:{build}",
                 f"stick-figure preview: {what} (write only)", suffixes=(f".{kind}",), write_only=True)


@hookimpl
def register_commands(subparsers):
    """``dance render`` (a preview of a motion file), ``dance retarget`` (a motion onto another rig) and
    ``dance convert`` (a motion into another format, rig, frame rate or units)."""
    from dance_core.cli import convert, render, retarget

    render.add_parser(subparsers)
    retarget.add_parser(subparsers)
    convert.add_parser(subparsers)
