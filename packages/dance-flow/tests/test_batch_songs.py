"""Songs composed in one batch (``compose.batch_songs``) with the flow head: Transflower (Gaussian and
Student-t bases, AR(1) correlated noise) and MoGlow each give every song what per-song generation gives
it, within float rounding; and a model that generated can then train (the relative-position cache)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from dance_core.compose import Song, batching_note, generate_song, generate_songs
from dance_core.model import build_model
from dance_core.protocols import TrainContext
from dance_core.recipe import load_recipe

MOTION_DIM, MUSIC_DIM = 6, 5
#: batched songs equal per-song generation within this (a row's products round differently in a larger
#: batch, and each step reads the frames before it)
TOLERANCE = 1e-3

SMALL_TRANSFLOWER = ["model.encoder.motion_past=6", "model.encoder.cond_past=6", "model.encoder.cond_future=3",
                     "model.encoder.dim=16", "model.head.coupling.dim=16", "model.head.steps=3"]
SMALL_MOGLOW = ["model.encoder.motion_frames=5", "model.encoder.music_past=5", "model.encoder.music_future=2",
                "model.encoder.steps=3", "model.encoder.hidden=16", "model.encoder.dim=16",
                "model.head.coupling.dim=16", "model.head.coupling.layers=1", "model.head.coupling.heads=2",
                "model.head.steps=3"]


def _model(name: str, *overrides: str):
    recipe = load_recipe(name, list(overrides))
    torch.manual_seed(0)
    model = build_model(recipe, MOTION_DIM, {"music": MUSIC_DIM})
    with torch.no_grad():  # untrained flows are near identity: make the noise and the music matter
        for p in model.parameters():
            p.add_(0.05 * torch.randn_like(p))
    return recipe, model.eval()


def _songs(model, lengths=(30, 41, 26)) -> list[Song]:
    rng = np.random.default_rng(0)
    start = model.start_frames()
    return [Song(f"s{k}", {"music": rng.standard_normal((start + n, MUSIC_DIM)).astype(np.float32)}, start + n)
            for k, n in enumerate(lengths)]


def _compare(recipe, model, songs) -> float:
    seed = torch.zeros(model.start_frames(), MOTION_DIM)
    cpu = torch.device("cpu")
    alone = [generate_song(model, s, seed, recipe, cpu) for s in songs]
    batched = generate_songs(model, songs, seed, recipe, cpu)
    again = generate_songs(model, songs, seed, recipe, cpu)
    worst = 0.0
    for s, a, b, c in zip(songs, alone, batched, again, strict=True):
        assert a.shape == b.shape == (recipe.compose.samples, s.n_frames, MOTION_DIM)
        assert np.array_equal(b, c)  # deterministic for a given batch
        worst = max(worst, float(np.abs(a - b).max()))
    assert worst <= TOLERANCE
    return worst


@pytest.mark.parametrize("base", ["gaussian", "student-t"])
@pytest.mark.parametrize("temperature", [0.0, 1.0])
def test_transflower_batched_songs_equal_per_song(base, temperature):
    recipe, model = _model("transflower-small", *SMALL_TRANSFLOWER, f"model.head.base={base}",
                           f"compose.temperature={temperature}", "compose.samples=2")
    assert model.head.correlation > 0  # the bundled recipe's AR(1) noise, carried per row in the state
    assert batching_note(model) is None
    songs = _songs(model)
    _compare(recipe, model, songs)
    if temperature > 0:  # the noise is real: a song's two samples differ, and songs differ
        seed = torch.zeros(model.start_frames(), MOTION_DIM)
        one = generate_song(model, songs[0], seed, recipe, torch.device("cpu"))
        assert np.abs(one[0] - one[1]).max() > 1e-2


def test_moglow_batched_songs_equal_per_song():
    recipe, model = _model("moglow", *SMALL_MOGLOW, "compose.temperature=1", "compose.samples=2")
    assert batching_note(model) is None
    _compare(recipe, model, _songs(model))


def test_a_model_can_train_after_generating_in_the_same_process():
    recipe, model = _model("transflower-small", *SMALL_TRANSFLOWER)
    songs = _songs(model, (4,))
    generate_song(model, songs[0], torch.zeros(model.start_frames(), MOTION_DIM), recipe, torch.device("cpu"))
    model.train()
    w = model.window
    past, span = w.motion_past, w.cond_past + w.cond_future
    motion = torch.randn(2, past + model.head.frames, MOTION_DIM)
    music = torch.randn(2, span, MUSIC_DIM)
    latent = model.encoder(motion[:, :past], model.condition({"music": music}))
    loss = model.head.loss(latent, motion[:, past:], motion[:, :past], TrainContext(step=0, epoch=0))["loss"]
    loss.backward()  # raised "Inference tensors cannot be saved for backward" with the cached index
    bias = [p for n, p in model.named_parameters() if n.endswith("table.weight")]
    assert bias and all(p.grad is not None and torch.isfinite(p.grad).all() for p in bias)
