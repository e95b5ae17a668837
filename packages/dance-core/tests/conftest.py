import pytest

from dance_core.recipe import load_recipe

TINY = [
    "data.dataset.songs=4",
    "data.dataset.seconds=6",
    "training.steps=40",
    "training.batch_size=16",
    "training.val_every=20",
    "training.checkpoint_every=20",
    "training.log_every=10",
]


@pytest.fixture
def tiny_recipe():
    """The bundled core recipe shrunk to train in a fraction of a second."""

    def make(*extra: str):
        return load_recipe("core-synthetic", [*TINY, *extra])

    return make
