"""What a command shows while and after it works: progress bars (rich, on stderr) and the lines saying what
it did (:func:`say`, silenced by ``-q``); no torch here, so light commands stay light."""

from __future__ import annotations

from argparse import Namespace
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.console import Console


@contextmanager
def progress_bar(quiet: bool, console: Console | None = None):
    """A rich progress display with a free-text ``info`` field; a no-op when quiet."""
    if quiet:
        yield None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        TextColumn("{task.fields[info]}"),
        console=console or Console(stderr=True),
        transient=False,
    )
    with progress:
        yield progress


def say(args: Namespace, *lines: str) -> None:
    """Print lines that say what a command did (files written, a summary) on stdout; none under ``-q``
    unless ``--json`` asks for them (they become its ``output``). What the user asked to see (a recipe, a
    list, a schema on stdout) is printed whatever ``-q`` says, and warnings and errors always are."""
    if getattr(args, "quiet", False) and not getattr(args, "json", False):
        return
    for line in lines:
        print(line)
