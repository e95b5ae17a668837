"""Checks only the ``dance`` command line makes: warnings, ``--shard``, ``--smpl-model`` (the checks of any
command's paths and numbers are public, in :mod:`dance_core.checks`)."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from dance_core.checks import check_input_file, either
from dance_core.errors import DanceError

if TYPE_CHECKING:
    from dance_core.contexts import FormatOptions


def warn(message: str) -> None:
    """One ``dance: warning: ...`` line on stderr."""
    print(f"dance: warning: {message}", file=sys.stderr)


def shard_arg(text: str):
    """An argparse ``type=`` for ``--shard I/N`` (:class:`dance_core.shards.Shard`); a bad value becomes
    ``argument --shard: expected I/N with 1 <= I <= N, got '3/2'``."""
    from dance_core.shards import Shard

    try:
        return Shard.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


shard_arg.__name__ = "shard"


def smpl_model_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--smpl-model PATH`` to a command that reads motion files (applied by :func:`use_smpl_model`)."""
    parser.add_argument(
        "--smpl-model", metavar="PATH",
        help="your SMPL body model (SMPL_NEUTRAL.pkl or .npz from smpl.is.tue.mpg.de, licensed by its authors): "
        "AIST++ SMPL pickles are read on its joints (sets DANCE_SMPL_MODEL, the smpl format's default `model`)",
    )


def use_smpl_model(args: argparse.Namespace) -> None:
    """Check ``--smpl-model`` and hand it to the smpl format through ``DANCE_SMPL_MODEL`` (as an absolute
    path, so processes this one starts, such as torchrun's, read the same file)."""
    given = getattr(args, "smpl_model", None)
    if not given:
        return
    from dance_core.formats.smpl_model import ENV_MODEL, SUFFIXES

    path = check_input_file(given, "--smpl-model", "SMPL model file")
    if path.suffix.lower() not in SUFFIXES:
        raise DanceError(f"--smpl-model {given}: an SMPL model file ends in {either(list(SUFFIXES))}")
    os.environ[ENV_MODEL] = str(path.resolve())


def check_smpl_model(files: Iterable[str | Path], formats: FormatOptions | None = None) -> None:
    """Before any heavy work: when one of ``files`` is read by the smpl format (AIST++ pickles), the SMPL
    model it needs is given (by ``formats``, a recipe's ``FormatOptions``, or the environment) and reads
    well; else the format's one-line error naming that file."""
    from dance_core.registry import get_registry

    registry = get_registry()
    for f in files:
        entry = registry.for_suffix("motion-format", Path(f).suffix)
        if entry is None or entry.name != "smpl":
            continue
        from dance_core.formats.smpl_model import load_body_model, missing_model

        model = (formats.build(entry) if formats is not None else entry.build()).model_path()
        if model is None:
            raise missing_model(f)
        load_body_model(model)  # read once and cached: a bad model file stops here too
        return
