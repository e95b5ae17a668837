"""Exactness of the flow's layers: invertibility, log-determinants, ActNorm init, LU inverse."""

from __future__ import annotations

import math

import pytest
import torch

from dance_flow.configs import CouplingConfig, FlowHeadConfig
from dance_flow.flow import (
    ActNorm,
    AffineCoupling,
    BatchNormFlow,
    FlowNet,
    GaussianBase,
    InvConv1x1,
    StudentTBase,
)

C, N, D_H = 5, 3, 4


def _randomize(module: torch.nn.Module, std: float = 0.3) -> None:
    """Move every parameter away from its (identity) initialization."""
    with torch.no_grad():
        for p in module.parameters():
            p.add_(torch.randn_like(p) * std)


def _tiny(norm: str, steps: int = 3) -> FlowNet:
    cfg = FlowHeadConfig(frames=N, steps=steps, norm=norm, coupling=CouplingConfig(dim=8, layers=1, heads=2))
    return FlowNet(C, D_H, N, cfg)


def _warm(flow: FlowNet, x: torch.Tensor, h: torch.Tensor) -> FlowNet:
    """Run one training batch (data-dependent init), perturb the weights, switch to eval."""
    flow.train()
    flow(x, h)
    _randomize(flow)
    return flow.eval()


def _layers():
    torch.manual_seed(0)
    cfg = CouplingConfig(dim=8, layers=1, heads=2)
    return [ActNorm(C), BatchNormFlow(C), InvConv1x1(C), AffineCoupling(C, D_H, N, cfg)]


@pytest.mark.parametrize("index", range(4), ids=["actnorm", "batchnorm", "invconv", "coupling"])
def test_each_layer_inverts_and_matches_brute_force_log_det(index):
    torch.manual_seed(1)
    layer = _layers()[index].double()
    x = torch.randn(2, N, C, dtype=torch.float64)
    h = torch.randn(2, N, D_H, dtype=torch.float64)
    layer.train()
    layer(x, h)
    _randomize(layer)
    layer.eval()
    z, logdet = layer(x, h)
    back, logdet_rev = layer.reverse(z, h)
    assert torch.allclose(back, x, atol=1e-10)
    assert torch.allclose(logdet, logdet_rev, atol=1e-10)
    for b in range(2):
        hb = h[b : b + 1]
        jac = torch.autograd.functional.jacobian(
            lambda v, hb=hb: layer(v.view(1, N, C), hb)[0].flatten(), x[b].flatten()
        )
        assert logdet[b].item() == pytest.approx(torch.linalg.slogdet(jac)[1].item(), abs=1e-8)


@pytest.mark.parametrize("norm", ["actnorm", "batchnorm", "none"])
def test_flow_inverts_within_1e4_and_log_det_is_exact(norm):
    torch.manual_seed(2)
    x, h = torch.randn(4, N, C) * 2 + 1, torch.randn(4, N, D_H)
    flow = _warm(_tiny(norm), x, h)
    with torch.no_grad():
        z, logdet = flow(x, h)
        back, logdet_rev = flow.reverse(z, h)
    assert (back - x).abs().max() < 1e-4
    assert not torch.allclose(z, x, atol=1e-2)  # the warmed flow is not the identity
    assert torch.allclose(logdet, logdet_rev, atol=1e-4)
    flow64 = flow.double()
    jac = torch.autograd.functional.jacobian(
        lambda v: flow64(v.view(1, N, C), h[:1].double())[0].flatten(), x[0].double().flatten()
    )
    assert logdet[0].item() == pytest.approx(torch.linalg.slogdet(jac)[1].item(), abs=1e-3)


def test_coupling_starts_as_the_identity():
    torch.manual_seed(3)
    cfg = CouplingConfig(dim=8, layers=1, heads=2)
    coupling = AffineCoupling(C, D_H, N, cfg)
    x, h = torch.randn(2, N, C), torch.randn(2, N, D_H)
    z, logdet = coupling(x, h)
    assert torch.allclose(z, x, atol=1e-6)
    assert torch.allclose(logdet, torch.zeros(2), atol=1e-5)


def test_actnorm_initializes_to_zero_mean_unit_variance_on_the_first_batch():
    torch.manual_seed(4)
    norm = ActNorm(C)
    x = torch.randn(64, N, C) * torch.tensor([1.0, 3.0, 0.8, 10.0, 2.0]) + torch.tensor([5.0, -2.0, 0.0, 1.0, 7.0])
    norm.train()
    z, _ = norm(x)
    flat = z.reshape(-1, C)
    assert torch.allclose(flat.mean(0), torch.zeros(C), atol=1e-5)
    assert torch.allclose(flat.std(0, unbiased=False), torch.ones(C), atol=1e-4)
    assert bool(norm.initialized)
    before = norm.logs.detach().clone()
    norm(x * 5)  # a second batch does not re-initialize
    assert torch.equal(norm.logs.detach(), before)


def test_actnorm_does_not_amplify_a_channel_that_is_still_in_the_first_batch():
    norm = ActNorm(C)
    x = torch.randn(64, N, C)
    x[..., 2] = 0.3  # still in this batch
    norm.train()
    norm(x)
    assert norm.logs[2].item() == pytest.approx(-math.log(0.5))
    assert norm.logs[0].item() == pytest.approx(-math.log(x[..., 0].std(unbiased=False).item()), abs=1e-5)


def test_actnorm_init_survives_a_state_dict_round_trip():
    norm = ActNorm(C)
    norm.train()
    norm(torch.randn(16, N, C) * 4)
    fresh = ActNorm(C)
    fresh.load_state_dict(norm.state_dict())
    fresh.train()
    x = torch.randn(16, N, C)
    assert torch.allclose(fresh(x)[0], norm(x)[0])


def test_lu_inverse_is_recomputed_after_an_optimizer_step():
    torch.manual_seed(5)
    conv = InvConv1x1(C)
    opt = torch.optim.SGD(conv.parameters(), lr=0.05)
    x = torch.randn(8, N, C)
    with torch.no_grad():
        first = conv.inverse().clone()
        assert conv.inverse() is conv.inverse()  # cached while the weights stay the same
    loss = (conv(x)[0] * torch.randn(8, N, C)).sum()  # a random direction: W stays well conditioned
    loss.backward()
    opt.step()
    with torch.inference_mode():
        w, w_inv = conv.weight(), conv.inverse()
        z, _ = conv(x)
        back, _ = conv.reverse(z)
    assert not torch.allclose(w_inv, first, atol=1e-4)
    assert torch.allclose(w_inv, torch.linalg.inv(conv.build_weight().double()).float(), atol=1e-6)
    assert torch.allclose(w @ w_inv, torch.eye(C), atol=1e-4)
    assert torch.allclose(back, x, atol=1e-4)


def test_lu_inverse_is_recomputed_after_loading_weights():
    torch.manual_seed(6)
    a, b = InvConv1x1(C), InvConv1x1(C)
    with torch.no_grad():
        a.inverse()
        a.load_state_dict(b.state_dict())
        assert torch.allclose(a.inverse(), b.inverse(), atol=1e-6)


def test_gaussian_and_student_t_log_densities_match_torch_distributions():
    z = torch.randn(3, N, 1)
    want = torch.distributions.Normal(0.0, 1.0).log_prob(z).sum((1, 2))
    assert torch.allclose(GaussianBase().log_prob(z), want, atol=1e-5)
    want_t = torch.distributions.StudentT(7.0).log_prob(z).sum((1, 2))  # C = 1: univariate t
    assert torch.allclose(StudentTBase(7.0).log_prob(z), want_t, atol=1e-5)


def test_student_t_samples_have_the_right_scale_and_are_seeded():
    base = StudentTBase(5.0)
    g1, g2 = torch.Generator().manual_seed(0), torch.Generator().manual_seed(0)
    a = base.sample((20000, 1, 1), 1.0, g1, "cpu", torch.float32)
    b = base.sample((20000, 1, 1), 1.0, g2, "cpu", torch.float32)
    assert torch.equal(a, b)
    assert a.var().item() == pytest.approx(5.0 / 3.0, rel=0.15)  # var of t(5) = df / (df - 2)
    assert torch.equal(base.sample((4, N, C), 0.0, g1, "cpu", torch.float32), torch.zeros(4, N, C))


def test_gaussian_log_density_normalizes_per_dimension():
    z = torch.zeros(1, N, C)
    assert GaussianBase().log_prob(z).item() == pytest.approx(-0.5 * math.log(2 * math.pi) * N * C)


@pytest.mark.parametrize("norm", ["actnorm", "batchnorm", "none"])
def test_fast_inversion_matches_reverse_and_follows_weight_updates(norm):
    torch.manual_seed(7)
    x, h = torch.randn(4, N, C), torch.randn(4, N, D_H)
    flow = _warm(_tiny(norm), x, h)
    z = torch.randn(4, N, C)
    with torch.inference_mode():
        assert torch.allclose(flow.invert(z, h), flow.reverse(z, h)[0], atol=1e-5)
    flow.train()
    opt = torch.optim.SGD(flow.parameters(), lr=0.01)
    (flow(x, h)[0] * torch.randn(4, N, C)).sum().backward()
    opt.step()
    flow.eval()
    with torch.inference_mode():
        assert torch.allclose(flow.invert(z, h), flow.reverse(z, h)[0], atol=1e-5)
