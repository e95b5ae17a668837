"""Invertible layers of the flow over ``(B, N, C)`` motion: norms, LU 1x1 convolution, coupling.

Every layer maps data ``x`` to latent ``z`` (``forward``) and back (``reverse``). Both return the
log-determinant of the *forward* Jacobian ``log|det dz/dx|`` per batch element, so that
``log p(x) = log p(z) + sum of log-dets`` whichever direction was run.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from dance_core import draw_rows
from dance_flow.attention import Transformer

SCALE_SHIFT = 2.0
SCALE_FLOOR = 1.0 - 1.0 / (1.0 + math.exp(-SCALE_SHIFT))  # makes the scale exactly 1 at zero


ACTNORM_MIN_STD = 0.5


class ActNorm(nn.Module):
    """Per-channel affine ``z = (x + bias) * exp(logs)``, initialized from the first training batch
    so that its output has zero mean and unit variance (Glow). Inputs are standardized, so a batch
    standard deviation below ``ACTNORM_MIN_STD`` means a channel that happens to be still in this
    batch: it is not amplified beyond ``1 / ACTNORM_MIN_STD``, or its later batches would explode."""

    def __init__(self, channels: int):
        super().__init__()
        self.bias = nn.Parameter(torch.zeros(channels))
        self.logs = nn.Parameter(torch.zeros(channels))
        self.register_buffer("initialized", torch.tensor(False))

    @torch.no_grad()
    def initialize(self, x: torch.Tensor) -> None:
        """Data-dependent initialization from a batch ``(B, N, C)``."""
        flat = x.reshape(-1, x.shape[-1])
        self.bias.copy_(-flat.mean(0))
        self.logs.copy_(-torch.log(flat.std(0, unbiased=False).clamp_min(ACTNORM_MIN_STD)))
        self.initialized.fill_(True)

    def forward(self, x: torch.Tensor, h: torch.Tensor | None = None):
        """Data to latent."""
        if self.training and not bool(self.initialized):
            self.initialize(x)
        logdet = self.logs.sum() * x.shape[1]
        return (x + self.bias) * self.logs.exp(), logdet.expand(x.shape[0])

    def reverse(self, z: torch.Tensor, h: torch.Tensor | None = None):
        """Latent to data."""
        logdet = self.logs.sum() * z.shape[1]
        return z * torch.exp(-self.logs) - self.bias, logdet.expand(z.shape[0])

    def reverse_affine(self) -> tuple[torch.Tensor, torch.Tensor]:
        """``(a, c)`` with ``reverse(z) = z * a + c``."""
        return torch.exp(-self.logs), -self.bias


class BatchNormFlow(nn.Module):
    """Batch normalization as an invertible layer (Real NVP): batch statistics in training, running
    statistics (started from the first batch, then a moving average) in evaluation and in
    ``reverse``. Log-parametrized scale, so it can never change sign."""

    def __init__(self, channels: int, momentum: float = 0.1, eps: float = 1e-5):
        super().__init__()
        self.momentum = momentum
        self.eps = eps
        self.log_gamma = nn.Parameter(torch.zeros(channels))
        self.beta = nn.Parameter(torch.zeros(channels))
        self.register_buffer("running_mean", torch.zeros(channels))
        self.register_buffer("running_var", torch.ones(channels))
        self.register_buffer("initialized", torch.tensor(False))

    def forward(self, x: torch.Tensor, h: torch.Tensor | None = None):
        """Data to latent."""
        if self.training:
            flat = x.reshape(-1, x.shape[-1])
            mean, var = flat.mean(0), flat.var(0, unbiased=False)
            with torch.no_grad():
                if bool(self.initialized):
                    self.running_mean.lerp_(mean.detach(), self.momentum)
                    self.running_var.lerp_(var.detach(), self.momentum)
                else:
                    self.running_mean.copy_(mean.detach())
                    self.running_var.copy_(var.detach())
                    self.initialized.fill_(True)
        else:
            mean, var = self.running_mean, self.running_var
        log_inv_std = -0.5 * torch.log(var + self.eps)
        z = (x - mean) * torch.exp(log_inv_std + self.log_gamma) + self.beta
        logdet = (log_inv_std + self.log_gamma).sum() * x.shape[1]
        return z, logdet.expand(x.shape[0])

    def reverse(self, z: torch.Tensor, h: torch.Tensor | None = None):
        """Latent to data, with the running statistics."""
        log_inv_std = -0.5 * torch.log(self.running_var + self.eps)
        x = (z - self.beta) * torch.exp(-log_inv_std - self.log_gamma) + self.running_mean
        logdet = (log_inv_std + self.log_gamma).sum() * z.shape[1]
        return x, logdet.expand(z.shape[0])

    def reverse_affine(self) -> tuple[torch.Tensor, torch.Tensor]:
        """``(a, c)`` with ``reverse(z) = z * a + c``."""
        a = torch.sqrt(self.running_var + self.eps) * torch.exp(-self.log_gamma)
        return a, self.running_mean - self.beta * a


class InvConv1x1(nn.Module):
    """Invertible channel mixing ``z_n = W x_n`` at every frame, with ``W = P L (U + diag(s))``.

    The log-determinant is ``N * sum(log|s|)``. Without gradients (evaluation, sampling) ``W`` and
    its inverse (computed in float64) are cached, keyed by the parameters' version counters, so
    any update of the weights (an optimizer step, loading a checkpoint) recomputes them.
    """

    def __init__(self, channels: int):
        super().__init__()
        q, _ = torch.linalg.qr(torch.randn(channels, channels, dtype=torch.float64))
        p, lower, upper = torch.linalg.lu(q)
        s = torch.diagonal(upper)
        eye = torch.eye(channels, dtype=torch.float64)
        self.register_buffer("perm", p.float())
        self.register_buffer("sign_s", torch.sign(s).float())
        self.register_buffer("lower_mask", torch.tril(torch.ones(channels, channels), -1))
        self.register_buffer("eye", eye.float())
        self.lower = nn.Parameter((lower - eye).float())
        self.upper = nn.Parameter(torch.triu(upper, 1).float())
        self.log_s = nn.Parameter(torch.log(s.abs()).float())
        self._cache: dict[str, tuple[tuple, torch.Tensor]] = {}

    def _key(self) -> tuple:
        return tuple((p._version, p.data_ptr(), p.device, p.dtype) for p in (self.lower, self.upper, self.log_s))

    def build_weight(self) -> torch.Tensor:
        """``W`` from its LU factors (differentiable)."""
        lower = self.lower * self.lower_mask + self.eye
        upper = self.upper * self.lower_mask.T + torch.diag(self.sign_s * torch.exp(self.log_s))
        return self.perm @ lower @ upper

    def _cached(self, which: str) -> torch.Tensor:
        if torch.is_grad_enabled() and self.lower.requires_grad:
            w = self.build_weight()
            return w if which == "weight" else torch.linalg.inv(w.double()).to(w.dtype)
        key = self._key()
        hit = self._cache.get(which)
        if hit is not None and hit[0] == key:
            return hit[1]
        w = self.build_weight()
        value = w if which == "weight" else torch.linalg.inv(w.double()).to(w.dtype)
        self._cache[which] = (key, value.detach())
        return value.detach()

    def weight(self) -> torch.Tensor:
        """The current ``W``."""
        return self._cached("weight")

    def inverse(self) -> torch.Tensor:
        """The current ``W^-1`` (recomputed whenever the weights changed)."""
        return self._cached("inverse")

    def forward(self, x: torch.Tensor, h: torch.Tensor | None = None):
        """Data to latent."""
        logdet = self.log_s.sum() * x.shape[1]
        return x @ self.weight().T, logdet.expand(x.shape[0])

    def reverse(self, z: torch.Tensor, h: torch.Tensor | None = None):
        """Latent to data."""
        logdet = self.log_s.sum() * z.shape[1]
        return z @ self.inverse().T, logdet.expand(z.shape[0])


class AffineCoupling(nn.Module):
    """Changes the first ``ceil(C/2)`` channels by ``z_a = (x_a + t) * scale``, with ``t`` and the
    bounded ``scale`` in (0.12, 1.12) from a transformer over the N frames of the other channels
    concatenated (channel-wise) with the latent tokens. Zero-initialized: starts as the identity."""

    def __init__(self, channels: int, cond_dim: int, frames: int, config):
        super().__init__()
        self.change = (channels + 1) // 2
        self.keep = channels - self.change
        self.inp = nn.Linear(self.keep + cond_dim, config.dim)
        self.net = Transformer(config.dim, config)
        self.out = nn.Linear(config.dim, 2 * self.change)
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)
        self.register_buffer("positions", torch.arange(frames), persistent=False)

    def affine(self, x_id: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Shift and log-scale ``(B, N, ceil(C/2))`` each, from the kept channels and the latent."""
        y = self.out(self.net(self.inp(torch.cat([x_id, h], dim=-1)), self.positions))
        shift, raw = y.chunk(2, dim=-1)
        log_scale = torch.log(torch.sigmoid(raw + SCALE_SHIFT) + SCALE_FLOOR)
        return shift, log_scale

    def invert(self, z: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        """Latent to data without the log-determinant (the sampling fast path)."""
        za, zb = z[..., : self.change], z[..., self.change :]
        hidden = F.linear(torch.cat([zb, h], dim=-1), self.inp.weight, self.inp.bias)
        y = F.linear(self.net(hidden, self.positions), self.out.weight, self.out.bias)
        shift, raw = y.chunk(2, dim=-1)
        xa = za / torch.sigmoid(raw + SCALE_SHIFT).add_(SCALE_FLOOR) - shift
        return torch.cat([xa, zb], dim=-1)

    def forward(self, x: torch.Tensor, h: torch.Tensor):
        """Data to latent."""
        xa, xb = x[..., : self.change], x[..., self.change :]
        shift, log_scale = self.affine(xb, h)
        za = (xa + shift) * log_scale.exp()
        return torch.cat([za, xb], dim=-1), log_scale.sum((1, 2))

    def reverse(self, z: torch.Tensor, h: torch.Tensor):
        """Latent to data."""
        za, zb = z[..., : self.change], z[..., self.change :]
        shift, log_scale = self.affine(zb, h)
        xa = za * torch.exp(-log_scale) - shift
        return torch.cat([xa, zb], dim=-1), log_scale.sum((1, 2))


class FlowStep(nn.Sequential):
    """norm -> invertible 1x1 convolution -> affine coupling."""

    def __init__(self, channels: int, cond_dim: int, frames: int, config):
        layers: list[nn.Module] = []
        if config.norm == "actnorm":
            layers.append(ActNorm(channels))
        elif config.norm == "batchnorm":
            layers.append(BatchNormFlow(channels, config.momentum))
        layers += [InvConv1x1(channels), AffineCoupling(channels, cond_dim, frames, config.coupling)]
        super().__init__(*layers)


class FlowNet(nn.Module):
    """``steps`` flow steps; ``forward`` maps data to latent, ``reverse`` latent to data."""

    def __init__(self, channels: int, cond_dim: int, frames: int, config):
        super().__init__()
        self.layers = nn.ModuleList(
            layer for _ in range(config.steps) for layer in FlowStep(channels, cond_dim, frames, config)
        )
        self.per_step = len(self.layers) // config.steps
        self._fused: dict[int, tuple[tuple, torch.Tensor, torch.Tensor]] = {}

    def _linear_parts(self, i: int) -> tuple[torch.Tensor, torch.Tensor]:
        """Step ``i``'s norm and 1x1 convolution reversed as one affine map ``y @ M + c``."""
        group = self.layers[i * self.per_step : (i + 1) * self.per_step]
        conv = group[-2]
        tensors = [t for m in group[:-1] for t in (*m.parameters(), *m.buffers())]
        key = tuple((t._version, t.data_ptr()) for t in tensors)
        hit = self._fused.get(i)
        if hit is not None and hit[0] == key:
            return hit[1], hit[2]
        matrix = conv.inverse().T
        offset = torch.zeros_like(matrix[0])
        if self.per_step == 3:
            a, c = group[0].reverse_affine()
            matrix, offset = matrix * a, c
        self._fused[i] = (key, matrix.contiguous(), offset)
        return self._fused[i][1], offset

    @torch.no_grad()
    def invert(self, z: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        """Latent to data without log-determinants, each step's norm and 1x1 convolution fused
        into one cached affine map (recomputed when any of their weights or statistics change)."""
        steps = len(self.layers) // self.per_step
        shape = z.shape
        for i in reversed(range(steps)):
            z = self.layers[(i + 1) * self.per_step - 1].invert(z, h)
            matrix, offset = self._linear_parts(i)
            z = torch.addmm(offset, z.reshape(-1, shape[-1]), matrix).view(shape)
        return z

    def forward(self, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``x (B, N, C)`` conditioned on ``h (B, N, d)`` -> ``z`` and ``log|det dz/dx|`` per element."""
        total = x.new_zeros(x.shape[0])
        for layer in self.layers:
            x, logdet = layer(x, h)
            total = total + logdet
        return x, total

    def reverse(self, z: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``z`` -> ``x`` and ``log|det dz/dx|`` at that ``x`` (the same sign as ``forward``)."""
        total = z.new_zeros(z.shape[0])
        for layer in reversed(self.layers):
            z, logdet = layer.reverse(z, h)
            total = total + logdet
        return z, total


class GaussianBase(nn.Module):
    """Standard normal base distribution over ``(N, C)``."""

    def log_prob(self, z: torch.Tensor) -> torch.Tensor:
        """Log density per batch element."""
        return (-0.5 * z.square() - 0.5 * math.log(2 * math.pi)).sum((1, 2))

    def sample(self, shape, temperature: float, generator, device, dtype) -> torch.Tensor:
        """Noise with standard deviation ``temperature``; a :class:`dance_core.RowGenerators` draws each
        group of rows from its own generator."""
        z = draw_rows(generator, shape[0], lambda g, n: torch.randn((n, *shape[1:]), generator=g, device=device,
                                                                    dtype=dtype))
        return z if temperature == 1.0 else z * temperature


class StudentTBase(nn.Module):
    """Multivariate Student-t with ``df`` degrees of freedom over the C channels, independent per
    frame; sampled as a Gaussian over a shared chi-square, with temperature scaling the Gaussian."""

    def __init__(self, df: float):
        super().__init__()
        self.df = float(df)

    def log_prob(self, z: torch.Tensor) -> torch.Tensor:
        """Log density per batch element."""
        c, nu = z.shape[-1], self.df
        const = math.lgamma((nu + c) / 2) - math.lgamma(nu / 2) - 0.5 * c * math.log(nu * math.pi)
        per_frame = const - 0.5 * (nu + c) * torch.log1p(z.square().sum(-1) / nu)
        return per_frame.sum(1)

    def sample(self, shape, temperature: float, generator, device, dtype) -> torch.Tensor:
        """Student-t noise; the Gaussian part has standard deviation ``temperature``. A
        :class:`dance_core.RowGenerators` draws each group of rows (its Gaussian, its chi-square seed and
        rejection loop) from its own generator."""
        return draw_rows(generator, shape[0],
                         lambda g, n: self._sample((n, *shape[1:]), temperature, g, device, dtype))

    def _sample(self, shape, temperature: float, generator, device, dtype) -> torch.Tensor:
        g = torch.randn(shape, generator=generator, device=device, dtype=dtype) * temperature
        seed = int(torch.randint(0, 2**62, (1,), generator=generator, device=device).item())
        gamma_gen = torch.Generator(device=device).manual_seed(seed)
        chi2 = _chi_square(self.df, shape[:-1], gamma_gen, device, dtype)
        return g / torch.sqrt(chi2 / self.df).unsqueeze(-1)


def _chi_square(df: float, shape, generator, device, dtype) -> torch.Tensor:
    """Chi-square samples by Marsaglia-Tsang gamma rejection, driven by ``generator``."""
    k = df / 2.0
    boost = k < 1.0
    a = k + 1.0 if boost else k
    d = a - 1.0 / 3.0
    c = 1.0 / math.sqrt(9.0 * d)
    out = torch.empty(shape, device=device, dtype=torch.float64).reshape(-1)
    todo = torch.arange(out.numel(), device=device)
    while todo.numel():
        n = todo.numel()
        x = torch.randn(n, generator=generator, device=device, dtype=torch.float64)
        u = torch.rand(n, generator=generator, device=device, dtype=torch.float64)
        v = (1.0 + c * x) ** 3
        ok = (v > 0) & (torch.log(u.clamp_min(1e-300)) < 0.5 * x * x + d - d * v + d * torch.log(v.clamp_min(1e-300)))
        out[todo[ok]] = d * v[ok]
        todo = todo[~ok]
    if boost:
        u = torch.rand(out.shape, generator=generator, device=device, dtype=torch.float64)
        out = out * u ** (1.0 / k)
    return (2.0 * out).reshape(shape).to(dtype)


def base_distribution(config) -> nn.Module:
    """The configured base distribution."""
    return StudentTBase(config.df) if config.base == "student-t" else GaussianBase()
