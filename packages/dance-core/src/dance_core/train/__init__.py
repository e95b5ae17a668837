"""Training: a run folder and the trainer that fills it.

- ``run_folder``: the folder's lock, files, log and resume checks (``RunFolder``, ``run_lock``, ``run_id``);
- ``data``: the recipe's data prepared (the step held-out evaluation shares), split and standardized;
- ``stages``: the stage of a step, a stage's parameters, a valid ``stop_at``;
- ``trainer``: the step loop (``Trainer``), on one process or every rank of a torchrun group;
- ``run``: ``train``, one run from its checks to its last checkpoint.
"""

from dance_core.train.data import TrainData, training_data
from dance_core.train.run import train
from dance_core.train.run_folder import (
    EMPTY_LOCK_GRACE_S,
    LOCK_FILE,
    LOG_FILE,
    MODEL_FILE,
    RECIPE_FILE,
    STATE_FILE,
    RunFolder,
    refuse_existing_run,
    run_dir_for,
    run_id,
    run_lock,
)
from dance_core.train.stages import check_stop_at, stage_at, trainable_parameters
from dance_core.train.trainer import Trainer, TrainResult

__all__ = [
    "EMPTY_LOCK_GRACE_S",
    "LOCK_FILE",
    "LOG_FILE",
    "MODEL_FILE",
    "RECIPE_FILE",
    "STATE_FILE",
    "RunFolder",
    "TrainData",
    "TrainResult",
    "Trainer",
    "check_stop_at",
    "run_dir_for",
    "refuse_existing_run",
    "run_id",
    "run_lock",
    "stage_at",
    "train",
    "trainable_parameters",
    "training_data",
]
