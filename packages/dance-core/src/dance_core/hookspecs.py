"""Hook specifications: one hook per component kind, each receiving a ``register`` callback.

Each kind's row in ``dance_core.kinds`` names its hook here; the functions stay written out because
pluggy reads their signatures and the docs their docstrings (``Register <the kind's description>.``).
``tests/test_kinds.py`` checks the two agree.
"""

from __future__ import annotations

import pluggy

hookspec = pluggy.HookspecMarker("dance")
hookimpl = pluggy.HookimplMarker("dance")


@hookspec
def register_conditioners(register):
    """Register conditioners: per-frame embeddings of one input stream."""


@hookspec
def register_encoders(register):
    """Register encoders: conditioning (and past motion) to a latent."""


@hookspec
def register_heads(register):
    """Register output heads: latent to motion frames (loss and sampling)."""


@hookspec
def register_feature_extractors(register):
    """Register feature extractors: audio or text to frame-aligned features."""


@hookspec
def register_audio_readers(register):
    """Register audio readers: a file of some suffixes to samples and a rate."""


@hookspec
def register_motion_formats(register):
    """Register motion formats: readers and writers of motion files."""


@hookspec
def register_motion_representations(register):
    """Register motion representations: skeletal motion to model features ``(T, D)`` and back."""


@hookspec
def register_datasets(register):
    """Register datasets: sources of paired music and motion clips."""


@hookspec
def register_metrics(register):
    """Register evaluation metrics over generated and reference motion."""


@hookspec
def register_schedules(register):
    """Register schedules: a value as a function of step and epoch (LR, curriculum)."""


@hookspec
def register_recipes(register):
    """Register bundled recipe files by name."""


@hookspec
def register_commands(subparsers):
    """Add ``dance`` subcommands: ``subparsers.add_parser(...)`` with ``set_defaults(run=fn)``."""
