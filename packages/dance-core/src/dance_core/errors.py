"""User-facing errors: each renders as one line naming the file and field at fault."""

from __future__ import annotations


class DanceError(Exception):
    """An error caused by the user's input; the CLI prints it as one line, without a traceback."""


class RecipeError(DanceError):
    """A recipe that cannot be parsed or validated."""


class PluginError(DanceError):
    """A plugin that is missing, misspelt, broken or clashing with another."""


class CheckpointError(DanceError):
    """A checkpoint that is missing, corrupt or does not match its recipe."""


class DataError(DanceError):
    """Input data (audio, motion, dataset) that cannot be used."""


class TrainingError(DanceError):
    """A training run that cannot go on (for instance a non-finite loss)."""


def describe_error(exc: BaseException) -> str:
    """One line for an error: a ``DanceError``'s own words, an ``OSError`` as ``FILE: reason``, out of memory
    with what to try, anything else its message (or its type's name)."""
    if isinstance(exc, MemoryError):
        detail = f" ({exc})" if str(exc) else ""
        return f"out of memory{detail}; try a shorter song, fewer songs or smaller sizes"
    if isinstance(exc, OSError) and not isinstance(exc, DanceError) and exc.filename is not None:
        where = f"{exc.filename} -> {exc.filename2}" if exc.filename2 is not None else str(exc.filename)
        return f"{where}: {exc.strerror or type(exc).__name__}"
    text = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    return text or type(exc).__name__
