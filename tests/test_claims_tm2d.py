"""TM2D's claims experiment (benchmarks/claims_tm2d.py): the strict jump (both feet 10 cm up in most of a
jump's airborne frames), the largest turn, and the verdict on paired bootstrap intervals with the energy
guard."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture
def tm2d(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))
    import claims_tm2d

    yield claims_tm2d
    for name in ("claims_tm2d", "claims_protocol", "text_spans", "readme_section"):
        sys.modules.pop(name, None)


def hopping(height: float, fps: float = 30.0, seconds: float = 8.0) -> np.ndarray:
    """A figure standing (SMPL-24 layout, hips 1 m up, feet at 0) that leaves the floor by ``height`` for
    0.4 s every 2 s, the whole body lifted."""
    n = int(seconds * fps)
    p = np.zeros((n, 24, 3))
    p[:, :, 1] = 1.0
    p[:, [7, 8, 10, 11], 1] = 0.0
    p[:, 1, 0], p[:, 2, 0] = 0.1, -0.1  # hips: left at +X, facing +Z
    lift = np.zeros(n)
    for s in np.arange(1.0, seconds - 1, 2.0):
        a = int(s * fps)
        lift[a:a + int(0.4 * fps)] = height
    return p + lift[:, None, None] * np.array([0.0, 1.0, 0.0])


def test_a_jump_counts_only_when_both_feet_clear_ten_cm(tm2d):
    high, clear = tm2d.jump_seconds(hopping(0.15), 30.0)
    assert high.sum() == 3 * 12 and clear.max() == pytest.approx(0.15)
    low, clear = tm2d.jump_seconds(hopping(0.07), 30.0)  # the detector sees a hop; a person sees no jump
    assert not low.any() and clear.max() == pytest.approx(0.07)
    stats = tm2d.move_stats("jump", hopping(0.15), 30.0, 0.0, 8.0)
    assert stats["share"] == pytest.approx(3 / 8) and stats["clearance_cm"] == pytest.approx(15.0)


def test_the_largest_turn_within_two_and_a_half_seconds(tm2d):
    p = hopping(0.0)
    yaw = np.radians(np.linspace(0.0, 360.0, len(p)))  # one turn in 8 s: 112.5° per 2.5 s
    p[:, 1, 0], p[:, 1, 2] = 0.1 * np.cos(yaw), -0.1 * np.sin(yaw)
    p[:, 2, 0], p[:, 2, 2] = -0.1 * np.cos(yaw), 0.1 * np.sin(yaw)
    assert tm2d.largest_turn(p, 30.0, 0, len(p)) == pytest.approx(112.5, abs=1.0)


def per_clip(slerp, fusion, a2d_speed=0.4, fusion_speed=0.4, units=6):
    out = {}
    for u in range(units):
        for arm, mpd, speed in (("slerp", slerp, 0.5), ("fusion", fusion, fusion_speed), ("a2d", fusion, a2d_speed)):
            for edge in ("start", "end"):
                j = 0.002 * u
                out[f"song{u % 2}|jump|{u}|{arm}|{edge}"] = {"mpd_10": mpd + j, "mpd_20": mpd + j, "mpd_30": mpd + j,
                                                             "mpd_speed": speed}
    return out


def moves():
    return {"jump": {a: [{"share": 0.0}] for a in ("a2d", "fusion", "slerp")},
            "clap": {"a2d": [{"share": 0.1}], "fusion": [{"share": 0.7}], "slerp": [{"share": 1.0}]}}


def test_the_rule_needs_every_interval_above_zero_and_no_stillness(tm2d):
    word, intervals, performed, speed = tm2d.verdict({"per_clip": per_clip(0.12, 0.05), "moves": moves()})
    assert word == "holds" and performed == ["clap"] and speed == pytest.approx(1.0)
    assert all(low > 0 for _, low, _ in intervals.values())
    # as coherent, but much stiller than the model's own music-only dancing: not a win
    word, *_ = tm2d.verdict({"per_clip": per_clip(0.12, 0.05, fusion_speed=0.1), "moves": moves()})
    assert word == "inconclusive"
    word, *_ = tm2d.verdict({"per_clip": per_clip(0.05, 0.12), "moves": moves()})
    assert word == "does not hold"
