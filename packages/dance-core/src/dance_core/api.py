"""``dance_core.api``: dance's loops for scripts, with typed options. ``dance`` itself runs through it.

    from dance_core import api

    recipe = api.load_recipe("core-synthetic", ["training.steps=200"])
    run = api.train(recipe, api.TrainOptions(out="runs/demo"))
    done = api.compose(recipe, api.ComposeOptions(music=["song.ogg"], checkpoint=run.checkpoint, out_dir="out"))
    report = api.evaluate("out", "data/dances")
    composer = api.Composer(recipe, run.checkpoint)     # the model loaded once: songs composed in memory

These names, like ``dance_core``'s, keep their meaning within a minor version. Benchmarks import only
them, ``dance_core``'s and the library modules ``dance_core.motion``, ``dance_core.evaluation`` and
``dance_core.synth`` (their ``__all__``); a test checks it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dance_core.checkpoint import Checkpoint, load_checkpoint
from dance_core.compose import (
    Composed,
    ComposeInputs,
    ComposeOptions,
    Song,
    batching_note,
    resolve_inputs,
    run_compose,
)
from dance_core.compose.composer import Composer
from dance_core.data.features import FeatureStack
from dance_core.data.files import read_motion_file
from dance_core.data.motion_info import MotionInfo
from dance_core.data.prepare import PreparedData
from dance_core.data.prepare import prepare_data as _prepare_data
from dance_core.data.sources import ClipSource
from dance_core.distributed import barrier, run_local
from dance_core.distributed import session as rank_session
from dance_core.evaluation.report import Report
from dance_core.formats.wav import write_wav
from dance_core.likelihood import held_out_nll
from dance_core.model import ComposedModel, build_model
from dance_core.motion.retarget import retarget
from dance_core.motion.torch_fk import RotationKinematics
from dance_core.protocols import JointClip, MotionData
from dance_core.recipe import Recipe, load_recipe
from dance_core.registry import get_registry
from dance_core.render.preview import render
from dance_core.train import Trainer, TrainResult, run_dir_for
from dance_core.train import train as _train

__all__ = [
    # recipes
    "Recipe",
    "load_recipe",
    # training
    "TrainOptions",
    "train",
    "run_dir",
    "Trainer",
    "TrainResult",
    "PreparedData",
    "prepare_data",
    # several processes on one machine
    "run_local",
    "rank_session",
    "barrier",
    # models
    "ComposedModel",
    "build_model",
    "stream_dims",
    # composition
    "ComposeOptions",
    "ComposeInputs",
    "resolve_inputs",
    "compose",
    "Composed",
    "Composer",
    "Song",
    "batching_note",
    # evaluation
    "EvaluateOptions",
    "evaluate",
    "Report",
    "held_out_nll",
    # checkpoints
    "Checkpoint",
    "RotationKinematics",
    "MotionInfo",
    "load_checkpoint",
    # files and motion
    "read_motion",
    "retarget",
    "write_wav",
    "render",
]


@dataclass(frozen=True)
class TrainOptions:
    """How one training runs: ``out`` the run folder (default ``training.output``), ``resume`` the run
    in it, ``stop_at`` a step to checkpoint and stop at, ``quiet`` without a progress bar, ``overwrite``
    replace a run already in the folder (else that is an error)."""

    out: str | Path | None = None
    resume: bool = False
    stop_at: int | None = None
    quiet: bool = False
    overwrite: bool = False


def train(recipe: Recipe, options: TrainOptions | None = None) -> TrainResult:
    """Train the recipe's model into its run folder (``dance train``; see ``dance_core.train.train``)."""
    o = options or TrainOptions()
    return _train(recipe, out=str(o.out) if o.out else None, resume=o.resume, quiet=o.quiet, stop_at=o.stop_at,
                  overwrite=o.overwrite)


def run_dir(recipe: Recipe, options: TrainOptions | None = None) -> Path:
    """The run folder a training writes: ``options.out``, else ``training.output`` for this recipe."""
    out = (options or TrainOptions()).out
    return run_dir_for(recipe, str(out) if out else None)


def prepare_data(recipe: Recipe, sources: Sequence[ClipSource] | None = None) -> PreparedData:
    """The recipe's data prepared as training and held-out NLL prepare it: its dataset (or ``sources``,
    clips as a dataset yields them) with motion encoded and features extracted. Prepared once, it can be
    handed to several ``Trainer``s on the same data and features (``Trainer(recipe, out, data=...)``)."""
    return _prepare_data(recipe, FeatureStack(recipe), get_registry(), sources)


def stream_dims(recipe: Recipe) -> dict[str, int]:
    """The width of each feature stream the recipe's extractors make (what ``build_model`` takes)."""
    return FeatureStack(recipe).dims()


def compose(recipe: Recipe | ComposeInputs, options: ComposeOptions | None = None) -> Composed:
    """Compose (``dance compose``): a recipe with ``options``, or inputs already resolved by
    :func:`resolve_inputs` (the CLI checks them in between). Returns what was written and skipped."""
    if isinstance(recipe, ComposeInputs):
        if options is not None:
            raise TypeError("compose: options are already applied to resolved inputs")
        return run_compose(recipe)
    return run_compose(resolve_inputs(recipe, options))


@dataclass(frozen=True)
class EvaluateOptions:
    """How :func:`evaluate` scores: ``metrics`` by name (default every registered metric), their
    ``metric_options``, ``compat`` (the papers' own computations); for folders, as ``dance evaluate``
    reads them: ``up`` axis, ``suffixes`` read, a common ``fps`` (default the reference's) and a
    ``music`` folder whose songs give the beat metrics their beats."""

    metrics: Sequence[str] | None = None
    metric_options: Mapping[str, Mapping[str, Any]] | None = None
    compat: bool = False
    up: str | None = None
    suffixes: Sequence[str] | None = None
    fps: float | None = None
    music: str | Path | None = None


def evaluate(
    generated: Sequence[JointClip] | str | Path,
    reference: Sequence[JointClip] | str | Path | None = None,
    options: EvaluateOptions | None = None,
) -> Report:
    """Score generated dances against reference dances with the registered metrics: ``JointClip``s, or
    folders of motion files read as ``dance evaluate`` reads them."""
    from dance_core.evaluation import loading
    from dance_core.evaluation.report import evaluate as score

    o = options or EvaluateOptions()
    registry = get_registry()
    notes: list[str] = []
    folders = isinstance(generated, str | Path)
    if folders:
        suffixes = list(o.suffixes) if o.suffixes else None
        ref = loading.load_clips(reference, registry, o.up, None, suffixes) if reference is not None else None
        gen = loading.load_clips(generated, registry, o.up, None, suffixes)
        fps = o.fps or loading.common_fps(ref if ref else gen)[0].fps
        generated, reference = loading.common_fps(gen, fps), loading.common_fps(ref, fps) if ref else None
        if o.music is not None:
            notes = loading.attach_music(generated, o.music, registry)
    options_by_metric = {k: dict(v) for k, v in o.metric_options.items()} if o.metric_options else None
    report = score(list(generated), list(reference) if reference is not None else None, o.metrics,
                   compat=o.compat, options=options_by_metric, registry=registry)
    report.notes[:0] = notes
    return report


def read_motion(path: str | Path, fmt: str | None = None) -> MotionData:
    """A motion file read with the format registered for its suffix (or the format named ``fmt``), at
    its defaults; ``.skeleton_motion`` holds its skeletal motion when it has one."""
    return read_motion_file(path, get_registry(), fmt)
