"""The local self-attention encoder: banded equals dense, receptive field, recipe errors."""

import pytest
import torch

from dance_core.errors import RecipeError
from dance_core.model import build_model
from dance_core.recipe import load_recipe
from dance_rnn.banded import banded_attention, dense_banded_attention
from dance_rnn.encoder import sinusoidal_positions


@pytest.mark.parametrize(
    ("n", "half", "block"),
    [(37, 5, None), (37, 5, 3), (64, 0, None), (10, 50, None), (100, 7, 16), (129, 16, 8), (1, 3, None)],
)
def test_banded_attention_equals_dense_band_masked_attention(n, half, block):
    gen = torch.Generator().manual_seed(n * 100 + half)
    q, k, v = (torch.randn(2, 3, n, 8, generator=gen) for _ in range(3))
    bias = torch.randn(3, 2 * half + 1, generator=gen)
    for params in ((q, k, v, bias), tuple(t.double() for t in (q, k, v, bias))):
        a = banded_attention(*params[:3], half, params[3], block)
        b = dense_banded_attention(*params[:3], half, params[3])
        assert a.shape == b.shape == (2, 3, n, 8)
        assert (a - b).abs().max().item() <= 1e-5


def test_banded_attention_gradients_equal_dense():
    gen = torch.Generator().manual_seed(1)
    q, k, v = (torch.randn(1, 2, 45, 4, generator=gen, requires_grad=True) for _ in range(3))
    bias = torch.randn(2, 13, generator=gen, requires_grad=True)
    grads = []
    for fn in (banded_attention, dense_banded_attention):
        out = fn(q, k, v, 6, bias)
        grads.append(torch.autograd.grad((out * torch.arange(45.0)[:, None]).sum(), (q, k, v, bias)))
    for a, b in zip(*grads, strict=True):
        assert torch.isfinite(a).all() and (a - b).abs().max().item() <= 1e-5


def test_banded_attention_bounds_scores_by_groups(monkeypatch):
    """Long sequences are processed block group by block group, with the same result."""
    import dance_rnn.banded as banded

    gen = torch.Generator().manual_seed(2)
    q, k, v = (torch.randn(1, 2, 300, 4, generator=gen) for _ in range(3))
    whole = banded_attention(q, k, v, 10)
    monkeypatch.setattr(banded, "GROUP_ELEMENTS", 2 * 16 * 48)  # one block per group
    assert torch.allclose(banded_attention(q, k, v, 10), whole, atol=1e-6)
    assert torch.allclose(whole, dense_banded_attention(q, k, v, 10), atol=1e-5)


def small_encoder(*overrides):
    recipe = load_recipe("dancerevolution-small", [f"model.encoder.{o}" for o in overrides])
    return build_model(recipe, 18, {"music": 4}).encoder.eval()


def test_receptive_field_is_k_over_two_per_layer():
    enc = small_encoder("layers=1", "k=6")  # |i - j| <= 3
    x = torch.randn(1, 40, 4)
    base = enc(None, {"music": x})
    y = x.clone()
    y[0, 20] += 5.0
    changed = (enc(None, {"music": y}) - base).abs().amax(-1)[0] > 1e-6
    assert changed.nonzero().flatten().tolist() == [17, 18, 19, 20, 21, 22, 23]
    enc2 = small_encoder("layers=2", "k=6")
    base2 = enc2(None, {"music": x})
    changed2 = (enc2(None, {"music": y}) - base2).abs().amax(-1)[0] > 1e-6
    assert changed2.nonzero().flatten().tolist() == list(range(14, 27))


def test_encoder_is_song_level_and_length_agnostic():
    enc = small_encoder()
    assert enc.window.song_level and enc.latent_tokens is None and enc.out_dim == 64
    for n in (1, 5, 333):
        assert enc(None, {"music": torch.randn(2, n, 4)}).shape == (2, n, 64)


def test_sinusoidal_positions_option():
    enc = small_encoder("position=sinusoidal")
    x = torch.zeros(1, 30, 4)
    out = enc(None, {"music": x})
    assert not torch.allclose(out[0, 3], out[0, 20])  # identical inputs, different positions
    table = sinusoidal_positions(4, 6)
    assert torch.allclose(table[0], torch.tensor([0.0, 1.0, 0.0, 1.0, 0.0, 1.0]))


def test_unknown_stream_is_a_one_line_recipe_error():
    recipe = load_recipe("dancerevolution-small", ["model.encoder.streams=[beats]"])
    with pytest.raises(RecipeError) as err:
        build_model(recipe, 18, {"music": 4})
    assert str(err.value) == "model.encoder: local-attention: streams: beats not among the feature streams (music)"
