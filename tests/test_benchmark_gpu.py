"""benchmarks/gpu_bench.py (what benchmarks/gpu.sh runs on a GPU) works: its --smoke mode measures the
small recipes of every family on CPU, counts FLOPs (LSTM included) and computes an MFU from a given peak."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench():
    pytest.importorskip("dance_flow")
    pytest.importorskip("dance_rnn")
    pytest.importorskip("dance_tokens")
    spec = importlib.util.spec_from_file_location("gpu_bench", ROOT / "benchmarks" / "gpu_bench.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["gpu_bench"] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop("gpu_bench", None)


def test_lstm_flops_are_counted_by_formula(bench):
    lstm = torch.nn.LSTM(8, 16, 2, batch_first=True)
    with bench.rnn_flops(lstm) as total:
        lstm(torch.randn(3, 5, 8))
    assert total[0] == 2 * 4 * 16 * (8 + 16) * 15 + 2 * 4 * 16 * (16 + 16) * 15


def test_peak_comes_from_the_table_or_the_environment(bench, monkeypatch):
    monkeypatch.delenv("DANCE_PEAK_TFLOPS", raising=False)
    assert bench.peak_flops(torch.device("cpu"))[0] is None
    monkeypatch.setenv("DANCE_PEAK_TFLOPS", "989")
    assert bench.peak_flops(torch.device("cpu")) == (989e12, "DANCE_PEAK_TFLOPS")
    assert bench.PEAK_TFLOPS["H100"] == bench.PEAK_TFLOPS["H200"] == 989.0


@pytest.mark.slow
def test_smoke_mode_measures_every_family_on_cpu(bench, monkeypatch, tmp_path):
    monkeypatch.setenv("DANCE_PEAK_TFLOPS", "0.5")
    out = tmp_path / "rows.json"
    rows = bench.run(smoke=True, train_steps=1, device="cpu", out=out, quiet=True)
    assert out.is_file()
    by = {(r["recipe"], r["what"], r.get("stage"), r["batch"]) for r in rows}
    for recipe in ("transflower-small", "dancerevolution-small"):
        assert {(recipe, "generate", None, 1), (recipe, "generate", None, 3), (recipe, "train", None, 2)} <= by
    assert {("tm2d-small", "train", "tokenizer", 2), ("tm2d-small", "train", "prior", 2)} <= by
    songs = {r["recipe"]: r["songs"] for r in rows if r["what"] == "generate" and r["batch"] == 3}
    assert songs == {"transflower-small": 3, "dancerevolution-small": 1, "tm2d-small": 1}  # compose.batch_songs
    for r in rows:
        if r["what"] == "generate":
            assert r["frames_per_s"] > 0 and r["s_per_s_music"] > 0
        else:
            assert r["gflop_per_step"] > 0 and r["samples_per_s"] > 0
            # TFLOP/s is rounded to 0.001, so over the 0.5 peak the MFU it implies is known to 0.001 only
            assert r["mfu"] == pytest.approx(r["tflops_achieved"] / 0.5, rel=0.05, abs=1.5e-3)
    trainable = {r["stage"]: r["params_M"] for r in rows if r["recipe"] == "tm2d-small" and r["what"] == "train"}
    assert trainable["tokenizer"] != trainable["prior"]  # each stage trains its own part
    text = bench.table(rows)
    assert ">= 200 frames/s" in text and "<= 0.02 s per s of music" in text and "MFU >= 40 %" in text
