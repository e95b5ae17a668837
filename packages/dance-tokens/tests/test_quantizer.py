"""The vector quantizer: nearest codes, the straight-through gradient, the losses, usage and restarts."""

import math

import torch

from dance_tokens.quantizer import VectorQuantizer, code_statistics


def quantizer(**kw):
    q = VectorQuantizer(4, 2, **kw)
    with torch.no_grad():
        q.codebook.copy_(torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [5.0, 5.0]]))
    return q


def test_each_vector_takes_its_nearest_code():
    q = quantizer()
    z = torch.tensor([[[0.1, -0.1], [0.9, 0.2], [0.2, 0.7], [4.0, 6.0], [0.6, 0.1]]])
    out = q(z)
    assert out.indices.tolist() == [[0, 1, 2, 3, 1]]
    torch.testing.assert_close(out.codes, q.codebook[out.indices])  # the forward pass gives the codes


def test_gradient_passes_straight_through_to_the_encoder_and_losses_split_by_stop_gradient():
    q = quantizer(beta=0.25)
    z = torch.tensor([[[0.1, -0.1], [0.9, 0.2]]], requires_grad=True)
    out = q(z)
    weights = torch.tensor([[[1.0, 2.0], [3.0, 4.0]]])
    (out.codes * weights).sum().backward()
    torch.testing.assert_close(z.grad, weights)  # the identity: d codes / d z = 1
    assert q.codebook.grad is None  # the reconstruction path never reaches the codebook
    e = q.codebook.detach()[[0, 1]][None]
    torch.testing.assert_close(out.codebook_loss, ((e - z.detach()) ** 2).mean())
    torch.testing.assert_close(out.commitment_loss, ((z.detach() - e) ** 2).mean())
    z.grad = None
    q.loss(out).backward()  # codebook loss moves the codes, beta x commitment moves the encoder
    torch.testing.assert_close(z.grad, 0.25 * 2 * (z.detach() - e) / z.numel())
    torch.testing.assert_close(q.codebook.grad[[0, 1]], 2 * (e - z.detach())[0] / z.numel())


def test_usage_and_perplexity():
    usage, perplexity = code_statistics(torch.tensor([0, 0, 1, 1]), 8)
    assert float(usage) == 2 / 8
    assert math.isclose(float(perplexity), 2.0, rel_tol=1e-6)  # two codes equally often
    usage, perplexity = code_statistics(torch.arange(8), 8)
    assert float(usage) == 1.0 and math.isclose(float(perplexity), 8.0, rel_tol=1e-6)


def test_dead_codes_are_restarted_from_the_batch_only_when_asked():
    z = torch.tensor([[[0.1, 0.0], [0.0, 0.1], [0.05, 0.05]]])
    off = quantizer()
    off.train()
    for _ in range(3):
        off(z)
    assert torch.equal(off.codebook.detach()[3], torch.tensor([5.0, 5.0]))
    on = quantizer(restart_after=2)
    on.train()
    gen = torch.Generator().manual_seed(0)
    on(z, gen)
    on(z, gen)  # codes 1, 2, 3 have now been idle for two batches
    assert on.idle.tolist() == [0, 2, 2, 2]
    on(z, gen)
    restarted = on.codebook.detach()[1:]
    assert all(any(torch.equal(code, row) for row in z[0]) for code in restarted)  # drawn from the batch
    on.eval()
    before = on.codebook.detach().clone()
    on(torch.full((1, 1, 2), 9.0))
    assert torch.equal(on.codebook.detach(), before)  # never in eval mode
