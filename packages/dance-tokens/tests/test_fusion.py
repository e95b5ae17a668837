"""The late-fusion weight curve and the runs of text spans it is laid over."""

import math

import torch

from dance_tokens.fusion import fusion_weights, span_runs


def test_weight_rises_along_a_half_cosine_holds_and_falls():
    w = fusion_weights(10, 0.8, 0.2)
    # token centres x = 0.05, 0.15 lie in the first 20 %: 0.8 (1 - cos(pi x / 0.2)) / 2 = 0.4 (1 -+ sqrt(1/2))
    rise = [0.4 * (1 - math.sqrt(0.5)), 0.4 * (1 + math.sqrt(0.5))]
    expected = rise + [0.8] * 6 + rise[::-1]
    assert all(math.isclose(a, b, rel_tol=0, abs_tol=1e-15) for a, b in zip(w.tolist(), expected, strict=True))
    assert w[2:8].tolist() == [0.8] * 6  # the hold is exactly the peak
    assert fusion_weights(1).tolist() == [0.8] and fusion_weights(2).tolist() == [0.8, 0.8]
    w = fusion_weights(20, 0.5, 0.25)
    assert torch.all(w[5:15] == 0.5) and torch.equal(w, w.flip(0)) and torch.all(torch.diff(w[:6]) > 0)
    assert 0 < float(w.min()) < 0.5


def test_runs_are_runs_of_one_span_and_adjacent_spans_stay_apart():
    index = torch.tensor([-1, 0, 0, 0, -1, 1, 1, 2, 2, -1])
    assert span_runs(index) == [(1, 4, 0), (5, 7, 1), (7, 9, 2)]
    assert span_runs(torch.tensor([3, 3])) == [(0, 2, 3)]
    assert span_runs(torch.tensor([-1, -1])) == []
    assert span_runs(torch.zeros(0, dtype=torch.long)) == []
    assert span_runs(torch.tensor([0, 1, 0])) == [(0, 1, 0), (1, 2, 1), (2, 3, 0)]  # interrupted: a new run
