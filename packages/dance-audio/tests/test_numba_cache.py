from __future__ import annotations

import os

from dance_audio.numba_cache import cache_dir, import_librosa


def test_librosa_kernels_are_cached_on_disk_including_the_uncached_beat_kernel():
    import_librosa()
    folder = cache_dir()
    assert os.environ["NUMBA_CACHE_DIR"] == str(folder)
    cached = {p.name for p in folder.rglob("*.nbi")}
    assert any("localmax" in name for name in cached), sorted(cached)  # librosa's own cache=True kernels
    # librosa declares this beat-tracking kernel cache=False; dance-audio caches it anyway
    assert any("beat_local_score" in name for name in cached), sorted(cached)


def test_cache_dir_follows_xdg_and_numba_variables(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_dir() == tmp_path / "dance" / "numba"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert cache_dir() == tmp_path / "elsewhere"
