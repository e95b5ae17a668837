from __future__ import annotations

import os

from dance_audio.numba_cache import cache_dir


def test_our_kernels_are_cached_on_disk():
    """Every compiled kernel of dance-audio lands in the cache directory, so only a machine's first
    run compiles (the figures in benchmarks/README.md depend on it)."""
    import numpy as np

    from dance_audio.dbn import DBNDownBeatTracker
    from dance_audio.hpss import hpss_masks
    from dance_audio.lstm_kernel import lstm_sequence

    out = np.zeros((4, 2), np.float32)
    lstm_sequence(np.zeros((4, 8), np.float32), np.zeros((2, 8), np.float32), np.zeros((3, 2), np.float32), True, out)
    hpss_masks(np.ones((40, 40), np.float32))
    DBNDownBeatTracker(beats_per_bar=[4], fps=100)(np.full((300, 2), 0.1, np.float32))
    folder = cache_dir()
    assert os.environ["NUMBA_CACHE_DIR"] == str(folder)
    cached = {p.name for p in folder.rglob("*.nbi")}
    for module in ("lstm_kernel", "hpss_kernels", "dbn"):
        assert any(name.startswith(module) for name in cached), (module, sorted(cached))


def test_cache_dir_follows_xdg_and_numba_variables(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_dir() == tmp_path / "dance" / "numba"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert cache_dir() == tmp_path / "elsewhere"
