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
