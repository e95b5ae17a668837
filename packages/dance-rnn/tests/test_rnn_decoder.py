"""The LSTM dance decoder: random initial state, seeded determinism, stateful generation."""

import pytest
import torch

from dance_core.errors import RecipeError
from dance_core.model import build_model
from dance_core.recipe import load_recipe


def small_model(*overrides, motion_dim=50):
    recipe = load_recipe("dancerevolution-small", list(overrides))
    return build_model(recipe, motion_dim, {"music": 4}).eval()


def generate(model, seed_value, n=60, batch=2):
    torch.manual_seed(123)
    music = torch.randn(1, n, 4).expand(batch, -1, -1)
    seed = torch.zeros(batch, 1, model.head.out.out_features)
    return model.generate({"music": music}, n, seed, generator=torch.Generator().manual_seed(seed_value))


def test_initial_state_is_standard_normal():
    head = small_model().head
    h, c = head.init_state(4000, torch.Generator().manual_seed(0))
    assert h.shape == c.shape == (3, 4000, 128)
    for x in (h, c):
        assert abs(x.mean().item()) < 0.01 and abs(x.std().item() - 1.0) < 0.01
    assert not torch.allclose(h, c)


def test_h0_noise_makes_samples_differ_and_a_fixed_seed_repeats_them():
    model = small_model()  # 50 channels: BODY_25 2D keypoints
    a = generate(model, 0)
    assert a.shape == (2, 60, 50)
    assert (a[0, 1:] - a[1, 1:]).abs().mean() > 1e-3  # same music, same seed pose, different h0
    assert torch.equal(a, generate(model, 0))
    assert (a - generate(model, 1)).abs().mean() > 1e-3


def test_generation_equals_a_fully_self_conditioned_rollout():
    """Stateful frame-by-frame generation is the training rollout with every input generated."""
    model = small_model("model.head.teacher_frames=1", motion_dim=18)
    music = torch.randn(2, 40, 4)
    seed = torch.randn(2, 1, 18)
    out = model.generate({"music": music}, 40, seed, generator=torch.Generator().manual_seed(3))
    with torch.no_grad():
        padded = torch.cat([music, music[:, -1:]], dim=1)  # generate() repeats the last frame once
        latent = model.encoder(None, model.condition({"music": padded}))
        pred, inputs = model.head.rollout(
            latent[:, 1:40], out[:, 1:], seed, q=10**6, generator=torch.Generator().manual_seed(3)
        )
    assert torch.allclose(pred, out[:, 1:], atol=1e-5)
    assert torch.allclose(inputs[:, 1:], out[:, 1:-1], atol=1e-5)


def test_temperature_does_not_change_the_deterministic_decoder():
    model = small_model(motion_dim=18)
    music, seed = torch.randn(1, 20, 4), torch.zeros(1, 1, 18)
    outs = [
        model.generate({"music": music}, 20, seed, temperature=t, generator=torch.Generator().manual_seed(0))
        for t in (0.0, 1.0, 2.0)
    ]
    assert torch.equal(outs[0], outs[1]) and torch.equal(outs[1], outs[2])


def test_windowed_encoder_is_rejected_with_a_one_line_error():
    recipe = load_recipe("core-synthetic", ["model.head={plugin: lstm-decoder}"])
    with pytest.raises(RecipeError) as err:
        build_model(recipe, 18, {"music": 4})
    assert str(err.value) == (
        "model.head: lstm-decoder: needs a song-level encoder (one latent per frame), got a windowed one"
    )


def test_paper_recipe_has_the_paper_sizes():
    recipe = load_recipe("dancerevolution")
    model = build_model(recipe, 50, {"music": 438})
    enc, head = model.encoder, model.head
    assert len(enc.layers) == 2 and enc.half == 50 and enc.out_dim == 1024
    attn = enc.layers[0].attention
    assert (attn.heads, attn.head_dim) == (8, 64) and enc.layers[0].ff[0].out_features == 1024
    assert enc.embed.in_features == 438
    assert (head.lstm.num_layers, head.lstm.hidden_size) == (3, 512)
    assert head.out.in_features == 512 + 1024 and head.out.out_features == 50
    assert head.config.teacher_frames == 10
    assert recipe.training.schedules["auto_condition"].plugin == "auto-condition-linear"
    assert recipe.training.schedules["auto_condition"].config.rate == 0.01
    assert recipe.data.segment_frames == 900 and recipe.fps == 15 and recipe.training.grad_clip is None
    assert [f.plugin for f in recipe.features["music"]] == ["librosa-438"]
    assert recipe.motion.plugin == "positions" and recipe.motion.config.dims == 2


def test_single_step_path_equals_the_lstm_module():
    head = small_model(motion_dim=18).head
    x, latent = torch.randn(4, 1, 18), torch.randn(4, 1, 64)
    state = head.init_state(4, torch.Generator().manual_seed(0))
    fast, (h1, c1) = head.run(x, latent, state)
    hidden, (h2, c2) = head.lstm(head.pose(x), state)
    assert torch.allclose(fast, head.out(torch.cat([hidden, latent], -1)), atol=1e-6)
    assert torch.allclose(h1, h2, atol=1e-6) and torch.allclose(c1, c2, atol=1e-6)
