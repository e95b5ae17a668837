"""What each rank runs in test_rnn_distributed.py (a module of its own: spawned ranks import it by name)."""

from __future__ import annotations

from dance_core.recipe import load_recipe

#: dancerevolution-small shrunk: 2 training songs of 2 s, 20-frame segments, q = epoch (an epoch is
#: 6 steps at a global batch of 8, so q goes 0, 1, 2 over 14 steps); h0 = 0 (init_scale 0), since
#: each rank draws its own initial states
TINY = [
    "features.music=[{plugin: energy}]",
    "data.dataset.songs=3",
    "data.dataset.seconds=2",
    "data.segment_frames=20",
    "model.encoder.dim=32",
    "model.encoder.layers=1",
    "model.encoder.ff_dim=64",
    "model.head.hidden=32",
    "model.head.layers=2",
    "model.head.init_scale=0.0",
    "training.steps=14",
    "training.log_every=2",
    "training.val_every=7",
    "training.val_batches=2",
    "training.checkpoint_every=7",
    "training.lr_schedule={plugin: constant}",
    "training.schedules.auto_condition={plugin: auto-condition-linear, rate: 1.0, offset: 0}",
]


def tiny(*extra: str):
    """The shrunk recipe with ``extra`` overrides."""
    return load_recipe("dancerevolution-small", [*TINY, *extra])


def run(out: str, batch: int):
    """Train the shrunk recipe on this rank; (steps, last loss, validation loss)."""
    from dance_core import distributed
    from dance_core.train import train

    with distributed.session():
        result = train(tiny(f"training.batch_size={batch}"), out=out, quiet=True)
    return result.steps, result.last_loss, result.val_loss
