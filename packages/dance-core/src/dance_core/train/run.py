"""``train``: one training run, from the checks made before any data is read to the last checkpoint."""

from __future__ import annotations

import contextlib

from dance_core import distributed
from dance_core.recipe.schema import Recipe
from dance_core.train.run_folder import refuse_existing_run, run_dir_for, run_lock
from dance_core.train.stages import check_stop_at
from dance_core.train.trainer import Trainer, TrainResult


def train(
    recipe: Recipe, out: str | None = None, resume: bool = False, quiet: bool = False, stop_at: int | None = None,
    overwrite: bool = False,
) -> TrainResult:
    """Train a recipe's model; the run folder holds checkpoint, state, log and resolved recipe.

    ``stop_at`` (a step in ``1..training.steps``) and the run folder's lock are checked before any
    data is read; so is a run already in the folder, which only ``resume`` (continue it) or ``overwrite``
    (replace it) may touch. A folder this call created is removed again if the run fails before writing to it.
    Started by torchrun (``RANK``/``WORLD_SIZE`` set), it joins the process group for the run and
    trains on every rank (``dance_core.distributed``); rank 0 alone locks and writes the run folder.
    """
    check_stop_at(stop_at, sum(s.steps for s in recipe.training.stage_list()))
    run_dir = run_dir_for(recipe, out)
    with distributed.session(recipe.training.device) as ranks:
        if not ranks.main:
            distributed.share_outcome()  # raises rank 0's error if it could not lock the run folder
            return Trainer(recipe, run_dir, quiet=True).run(resume=resume, stop_at=stop_at)
        created = not run_dir.exists()
        try:
            with contextlib.ExitStack() as stack:
                try:
                    stack.enter_context(run_lock(run_dir))
                    if not resume and not overwrite:
                        refuse_existing_run(run_dir)
                except BaseException as exc:
                    distributed.share_outcome(exc)
                    raise
                distributed.share_outcome(None)
                return Trainer(recipe, run_dir, quiet).run(resume=resume, stop_at=stop_at)
        except BaseException:
            if created and run_dir.is_dir() and not any(run_dir.iterdir()):
                run_dir.rmdir()
            raise
