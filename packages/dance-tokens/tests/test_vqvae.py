"""The motion VQ-VAE: t = 8 frames per token, 3 layers each way, and the decoder's exact token reach."""

import torch

from dance_tokens.configs import TokenizerConfig
from dance_tokens.vqvae import MotionVQVAE


def vqvae(**kw):
    torch.manual_seed(0)
    return MotionVQVAE(6, TokenizerConfig(codes=32, code_dim=8, width=16, **kw))


def test_shapes_and_layers():
    model = vqvae()
    motion = torch.randn(2, 64, 6)
    tokens = model.encode(motion)
    assert tokens.shape == (2, 8) and tokens.dtype == torch.long
    assert model.decode(tokens).shape == (2, 64, 6)
    assert model.encode(torch.randn(2, 70, 6)).shape == (2, 8)  # frames past the last whole token dropped
    strided = [m for m in model.encoder if isinstance(m, torch.nn.Conv1d) and m.stride == (2,)]
    assert len(strided) == 3  # t = 8: three stride-2 layers (the paper's 3-layer encoder)
    assert len([m for m in model.decoder if isinstance(m, torch.nn.Upsample)]) == 3
    out = model.loss(motion)
    assert set(out) == {"loss", "recon", "commitment", "usage", "perplexity"}
    assert vqvae(downsample=4).encode(motion).shape == (2, 16)


def test_receptive_field_is_exact():
    model = vqvae()
    assert model.receptive_field() == (4, 4)  # a frame depends on at most 4 tokens either side of its own
    tokens = torch.randint(0, 32, (1, 24), generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        base = model.decode(tokens)
        for s in (0, 3, 10, 23):
            changed = tokens.clone()
            changed[0, s:] = (changed[0, s:] + 1) % 32
            diff = (model.decode(changed) - base).abs().sum(-1)[0]
            first = model.first_frame_reached(s)
            assert torch.all(diff[:first] == 0), s  # bit for bit before the boundary
            assert diff[first] > 0, s  # and the boundary frame changes
            assert model.token_reach(first)[1] >= s
            assert first == 0 or model.token_reach(first - 1)[1] < s


def with_loss_options(**kw):
    """A motion, a VQ-VAE with the default losses and the same weights with the loss options ``kw``, and both
    losses on the motion."""
    torch.manual_seed(0)
    motion = torch.randn(2, 32, 6)
    plain, other = vqvae(), vqvae(**kw)
    other.load_state_dict(plain.state_dict())
    return motion, plain, plain.loss(motion), other.loss(motion)


def test_velocity_and_acceleration_losses_add_the_differences_l1():
    motion, plain, base, extra = with_loss_options(velocity=0.5, acceleration=2.0)
    assert "velocity" not in base
    recon, _ = plain(motion)
    vel = (recon.diff(dim=1) - motion.diff(dim=1)).abs().mean()
    acc = (recon.diff(n=2, dim=1) - motion.diff(n=2, dim=1)).abs().mean()
    assert torch.isclose(extra["velocity"], vel) and torch.isclose(extra["acceleration"], acc)
    assert torch.isclose(extra["loss"], base["loss"] + 0.5 * vel + 2.0 * acc)


def test_root_channels_weigh_root_weight_in_the_reconstruction():
    motion, plain, base, out = with_loss_options(root_channels=2, root_weight=5.0)
    recon, _ = plain(motion)
    err = (recon - motion).abs()  # L1 (the config's default)
    expected = (err[..., :2].sum() * 5.0 + err[..., 2:].sum()) / err.numel()
    assert torch.isclose(out["loss"] - base["loss"], expected - err.mean(), atol=1e-6)
    assert torch.isclose(out["recon"], base["recon"])  # the logged L1 error stays unweighted
