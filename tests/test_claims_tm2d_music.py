"""TM2D's music-only-quality experiment (benchmarks/claims_tm2d_music.py): the non-inferiority reading of a
difference's interval against its margin, and the verdict over seeds' bootstrap intervals."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture
def music(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))
    import claims_tm2d_music

    yield claims_tm2d_music
    for name in ("claims_tm2d_music", "claims_protocol", "readme_section"):
        sys.modules.pop(name, None)


def test_an_interval_is_read_against_its_margin_on_the_worse_side(music):
    # distance: higher is worse, the margin at +0.1
    assert music.non_inferior((0.0, -0.2, 0.09), 0.1) == "within"
    assert music.non_inferior((0.2, 0.11, 0.3), 0.1) == "beyond"
    assert music.non_inferior((0.1, 0.05, 0.15), 0.1) == "straddles"
    # locking: higher is better, the margin at -0.05
    assert music.non_inferior((0.0, -0.04, 0.3), 0.05, higher_is_worse=False) == "within"
    assert music.non_inferior((-0.1, -0.2, -0.06), 0.05, higher_is_worse=False) == "beyond"
    assert music.non_inferior((-0.05, -0.1, 0.0), 0.05, higher_is_worse=False) == "straddles"
    assert music.non_inferior((None, None, None), 0.05) == "n/a"


def test_the_verdict_over_seeds(music):
    same = {"ratio": 0.5, "locking": 0.45}
    scores = {"text": [dict(same, ratio=0.5 + 0.01 * k) for k in range(5)],
              "music": [dict(same, ratio=0.5 - 0.01 * k) for k in range(5)]}
    judged = music.judge(scores)
    assert judged["readings"] == {"distance": "within", "locking": "within"} and judged["verdict"] == "holds"
    worse = {"text": [dict(same, locking=0.3 + 0.01 * k) for k in range(5)], "music": scores["music"]}
    judged = music.judge(worse)  # locking 0.15 lower on every seed: wholly past -0.05
    assert judged["readings"]["locking"] == "beyond" and judged["verdict"] == "does not hold"
    spread = {"text": [dict(same, ratio=r) for r in (0.3, 0.9, 0.4, 0.8, 0.5)], "music": scores["music"]}
    assert music.judge(spread)["verdict"] == "inconclusive"
    assert music.verdict(["within", "n/a"]) == "n/a"
