"""The flow head's likelihood and sampling, and the encoders' positions and shapes."""

from __future__ import annotations

import math

import pytest
import torch

from dance_core.data.motion_info import MotionInfo
from dance_core.protocols import TrainContext
from dance_flow.attention import RelativeBias, Transformer, relative_buckets
from dance_flow.configs import (
    CouplingConfig,
    FlowHeadConfig,
    MoGlowContextConfig,
    TransflowerEncoderConfig,
    TransformerConfig,
)
from dance_flow.encoder import TransflowerEncoder
from dance_flow.head import FlowHead
from dance_flow.moglow import MoGlowContext

D, N, H = 4, 3, 6
CTX = TrainContext(step=0, epoch=0)


def _head(base: str = "gaussian", norm: str = "actnorm") -> FlowHead:
    torch.manual_seed(0)
    cfg = FlowHeadConfig(
        frames=N, steps=4, norm=norm, base=base, df=6.0, coupling=CouplingConfig(dim=16, layers=1, heads=2)
    )
    return FlowHead(cfg, D, H)


def _toy(batch: int, generator: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """Latents and frames from a conditional distribution: a mean set by h, correlated noise."""
    h = torch.randn(batch, N, H, generator=generator)
    mean = torch.tanh(h[..., :D] * 2)
    noise = torch.randn(batch, N, D, generator=generator) * 0.1
    return h, mean + noise + noise.roll(1, dims=-1)


@pytest.mark.parametrize("base", ["gaussian", "student-t"])
def test_nll_falls_when_fitting_a_conditional_distribution(base):
    head = _head(base)
    opt = torch.optim.Adam(head.parameters(), lr=3e-3)
    g = torch.Generator().manual_seed(1)
    val_h, val_x = _toy(256, torch.Generator().manual_seed(99))
    head.eval()
    with torch.no_grad():
        before = head.loss(val_h, val_x, None, CTX)["loss"].item()
    head.train()
    for _ in range(150):
        h, x = _toy(64, g)
        loss = head.loss(h, x, None, CTX)["loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()
    head.eval()
    with torch.no_grad():
        after = head.loss(val_h, val_x, None, CTX)["loss"].item()
        samples, _ = head.sample(val_h, 1.0, torch.Generator().manual_seed(3))
    assert after < before - 1.0  # bits per dimension
    # the samples follow the conditional mean, so the model uses the latent
    err = (samples - torch.tanh(val_h[..., :D] * 2)).abs().mean().item()
    assert err < 0.25


def test_loss_is_bits_per_dimension_of_the_exact_likelihood():
    head = _head().eval()
    h, x = _toy(8, torch.Generator().manual_seed(0))
    with torch.no_grad():
        out = head.loss(h, x, None, CTX)
        log_p = head.log_prob(x, h)
    assert out["loss"].item() == pytest.approx(-log_p.mean().item() / (N * D * math.log(2)), rel=1e-5)


def test_sample_log_likelihood_has_the_right_sign_and_matches_the_forward_density():
    head = _head("student-t")
    head.train()
    h, x = _toy(16, torch.Generator().manual_seed(0))
    head.loss(h, x, None, CTX)  # actnorm init
    with torch.no_grad():
        for p in head.parameters():
            p.add_(torch.randn_like(p) * 0.05)
    head.eval()
    with torch.no_grad():
        samples, log_p = head.sample(h, 1.0, torch.Generator().manual_seed(5))
        assert torch.allclose(log_p, head.log_prob(samples, h), atol=1e-3)
        _, log_p_cold = head.sample(h, 0.0, torch.Generator().manual_seed(5))
    # the base mode maps to a point of higher density than typical samples
    assert (log_p_cold > log_p).float().mean() > 0.9


def test_sampling_shapes_seeds_and_temperature():
    head = _head().eval()
    h = torch.randn(5, N, H)
    with torch.inference_mode():
        a, _ = head.sample(h, 1.0, torch.Generator().manual_seed(0))
        b, _ = head.sample(h, 1.0, torch.Generator().manual_seed(0))
        c, _ = head.sample(h, 1.0, torch.Generator().manual_seed(1))
        cold1, _ = head.sample(h, 0.0, torch.Generator().manual_seed(0))
        cold2, _ = head.sample(h, 0.0, torch.Generator().manual_seed(7))
        frames, state = head.step(h, torch.zeros(5, 0, D), head.init_state(5), 0.0, None)
    assert a.shape == (5, N, D)
    assert torch.equal(a, b) and not torch.allclose(a, c)
    assert torch.equal(cold1, cold2) and torch.equal(frames, cold1) and state is None
    assert not torch.allclose(cold1, a)


def test_relative_buckets_are_signed_monotone_and_saturate():
    offsets = torch.arange(-300, 301)
    b = relative_buckets(offsets, 32, 128)
    before, after = b[offsets < 0], b[offsets > 0]
    assert b[offsets == 0].item() == 0
    assert set(before.tolist()).isdisjoint(after.tolist())
    assert torch.all(before.flip(0)[1:] >= before.flip(0)[:-1])  # farther back, same or later bucket
    assert torch.all(after[1:] >= after[:-1])
    assert b.max().item() == 31 and relative_buckets(torch.tensor([1000]), 32, 128).item() == 31
    assert relative_buckets(torch.tensor([-1, -2, -3]), 32, 128).tolist() == [1, 2, 3]  # exact near 0


def test_relative_bias_is_translation_invariant_and_positions_matter():
    torch.manual_seed(0)
    stack = Transformer(16, TransformerConfig(layers=2, heads=4)).eval()
    with torch.no_grad():
        stack.bias.table.weight.normal_(0, 1.0)
    x = torch.randn(2, 10, 16)
    pos = torch.arange(-7, 3)
    with torch.no_grad():
        y = stack(x, pos)
        shifted = stack(x, pos + 37)
        spread = stack(x, pos * 3)
    assert torch.allclose(y, shifted, atol=1e-6)
    assert not torch.allclose(y, spread, atol=1e-3)
    bias = RelativeBias(4)
    assert bias(torch.arange(5)).shape == (1, 4, 5, 5)


def _encoder(latent: str) -> TransflowerEncoder:
    torch.manual_seed(0)
    layer = TransformerConfig(layers=1, heads=2, dropout=0.1)
    cfg = TransflowerEncoderConfig(
        motion_past=6,
        cond_past=5,
        cond_future=2,
        dim=8,
        motion=layer,
        music=layer,
        crossmodal=layer,
        tokens=N,
        latent=latent,
    )
    return TransflowerEncoder(cfg, D, {"music": 3, "text": 2})


@pytest.mark.parametrize("latent", ["prefix", "queries"])
def test_transflower_encoder_shapes_and_dependence_on_every_input(latent):
    enc = _encoder(latent).eval()
    motion = torch.randn(2, 6, D)
    cond = {"music": torch.randn(2, 7, 3), "text": torch.randn(2, 7, 2)}
    with torch.no_grad():
        out = enc(motion, cond)
        moved_motion = enc(motion + 1, cond)
        moved_music = enc(motion, {**cond, "music": cond["music"] + 1})
    assert out.shape == (2, N, 8) and enc.latent_tokens == N and enc.out_dim == 8
    assert enc.window.motion_past == 6 and enc.window.cond_past == 5 and enc.window.cond_future == 2
    assert not torch.allclose(out, moved_motion) and not torch.allclose(out, moved_music)


def test_encoder_config_rejects_heads_that_do_not_divide_the_width():
    with pytest.raises(ValueError, match="must divide dim"):
        TransflowerEncoderConfig(dim=30, crossmodal=TransformerConfig(heads=4))


def test_moglow_context_sees_exactly_its_recent_frames():
    torch.manual_seed(0)
    cfg = MoGlowContextConfig(motion_frames=4, music_past=3, music_future=2, steps=5, hidden=8, dim=6, tokens=2)
    enc = MoGlowContext(cfg, D, {"music": 3}).eval()
    w = enc.window
    assert (w.motion_past, w.cond_past, w.cond_future) == (8, 7, 2)
    motion, music = torch.randn(1, 8, D), torch.randn(1, 9, 3)
    with torch.no_grad():
        out = enc(motion, {"music": music})
        music2 = music.clone()
        music2[:, -1] += 5  # the last music frame: only the last LSTM position sees it
        out2 = enc(motion, {"music": music2})
    assert out.shape == (1, 2, 6)
    assert torch.allclose(out[:, 0], out2[:, 0]) and not torch.allclose(out[:, 1], out2[:, 1])


def test_residual_head_models_frames_relative_to_the_last_one():
    torch.manual_seed(0)
    cfg = FlowHeadConfig(frames=N, steps=2, residual=True, coupling=CouplingConfig(dim=8, layers=1, heads=2))
    head = FlowHead(cfg, D, H).eval()
    assert head.history_frames == 1
    h, x = _toy(4, torch.Generator().manual_seed(0))
    last = torch.randn(4, 1, D)
    with torch.no_grad():
        loss = head.loss(h, x + last, last, CTX)["loss"]
        direct = -head.log_prob(x, h).mean() / (N * D * math.log(2))
        frames, _ = head.step(h, last, None, 0.0, None)
        cold, _ = head.sample(h, 0.0)
    assert loss.item() == pytest.approx(direct.item(), rel=1e-5)
    assert torch.allclose(frames, cold + last, atol=1e-6)


def test_correlated_sampling_keeps_each_steps_noise_and_shares_it_between_steps():
    torch.manual_seed(0)
    cfg = FlowHeadConfig(frames=N, steps=2, coupling=CouplingConfig(dim=8, layers=1, heads=2), sample_correlation=0.9)
    head = FlowHead(cfg, D, H).eval()
    head.flow.invert = lambda z, latent: z  # look at the base noise itself
    h = torch.zeros(4096, N, H)
    gen = torch.Generator().manual_seed(1)
    state = head.init_state(4096, gen)
    with torch.no_grad():
        zs = []
        for _ in range(3):
            z, state = head.step(h, None, state, 0.5, gen)
            zs.append(z)
    for z in zs:
        assert z.std().item() == pytest.approx(0.5, rel=0.03)  # the temperature's spread at every step
    corr = torch.corrcoef(torch.stack([zs[1].flatten(), zs[2].flatten()]))[0, 1]
    assert corr.item() == pytest.approx(0.9, abs=0.02)
    independent = FlowHead(FlowHeadConfig(frames=N, steps=2, coupling=CouplingConfig(dim=8, layers=1, heads=2)), D, H)
    assert independent.init_state(4, gen) is None


def test_a_generation_only_option_does_not_stop_a_checkpoint_from_loading(tmp_path):
    from dance_core.checkpoint import check_matches, load_checkpoint, save_checkpoint
    from dance_core.data.stats import NormStats
    from dance_core.errors import CheckpointError
    from dance_core.model import build_model
    from dance_core.recipe import load_recipe

    small = ["model.encoder.dim=16", "model.encoder.motion={layers: 1, heads: 2}",
             "model.encoder.music={layers: 1, heads: 2}", "model.encoder.crossmodal={layers: 1, heads: 2}",
             "model.head.coupling={dim: 8, layers: 1, heads: 2}", "model.head.steps=2"]
    recipe = load_recipe("transflower-small", small)
    model = build_model(recipe, 6, {"music": 81, "beat": 6})
    from dance_core.data.sources import Clip

    rng = torch.Generator().manual_seed(0)
    streams = {"music": torch.randn(9, 81, generator=rng).numpy(), "beat": torch.randn(9, 6, generator=rng).numpy()}
    stats = NormStats.fit([Clip("a", torch.randn(9, 6, generator=rng).numpy(), streams)])
    path = tmp_path / "model.safetensors"
    save_checkpoint(path, model, stats, recipe, MotionInfo(dim=6, fps=20.0), 1)
    ckpt = load_checkpoint(path)
    check_matches(ckpt, load_recipe("transflower-small", [*small, "model.head.sample_correlation=0.95"]))
    # the beat tracker is an input option of the same kind: the beat columns mean the same whoever tracked them
    check_matches(ckpt, load_recipe("transflower-small", [*small, "features.beat=[{plugin: beats, tracker: madmom}]"]))
    with pytest.raises(CheckpointError, match=r"features\.beat"):
        check_matches(ckpt, load_recipe("transflower-small", [*small, "features.beat=[{plugin: beats, max_bpm: 200}]"]))
    with pytest.raises(CheckpointError, match=r"model\.head\.steps"):
        check_matches(ckpt, load_recipe("transflower-small", [*small[:-1], "model.head.steps=3"]))
