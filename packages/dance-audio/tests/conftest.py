"""Shared fixtures: the real music under ../shared/fixtures/audio and synthetic click tracks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dance_core.media import Audio

REPO = Path(__file__).resolve().parents[3]
AUDIO_DIR = REPO.parent / "shared" / "fixtures" / "audio"


def clicks(times, seconds: float, rate: int = 22050) -> Audio:
    """Short decaying 2 kHz bursts starting at ``times`` over a quiet noise floor."""
    rng = np.random.default_rng(0)
    y = 1e-3 * rng.standard_normal(int(round(seconds * rate))).astype(np.float32)
    n = int(0.03 * rate)
    burst = np.sin(2 * np.pi * 2000 * np.arange(n) / rate) * np.exp(-np.arange(n) / (0.006 * rate))
    for t in times:
        i = int(round(t * rate))
        y[i : i + n] += 0.8 * burst[: len(y) - i]
    return Audio(y.astype(np.float32), rate)


@pytest.fixture(scope="session")
def make_clicks():
    """The click-track builder, as a fixture (test modules cannot import conftest)."""
    return clicks


@pytest.fixture(scope="session")
def audio_dir() -> Path:
    assert AUDIO_DIR.is_dir(), f"fixtures missing: {AUDIO_DIR}"
    return AUDIO_DIR


@pytest.fixture(scope="session")
def registry():
    from dance_core.registry import get_registry

    return get_registry()


@pytest.fixture(scope="session")
def sample(audio_dir, registry) -> Audio:
    from dance_core.data.features import load_audio

    return load_audio(audio_dir / "sample.wav", registry)


@pytest.fixture(scope="session")
def annotated_beats(audio_dir) -> tuple[np.ndarray, np.ndarray]:
    rows = [
        line.split()
        for line in (audio_dir / "sample.beats").read_text().splitlines()
        if line.strip() and not line.startswith("#")
    ]
    return np.array([float(r[0]) for r in rows]), np.array([int(r[1]) for r in rows])


@pytest.fixture(scope="session")
def librosa():
    """librosa, the reference our librosa-free features are checked against (a test dependency only)."""
    from dance_audio.numba_cache import use_cache_dir

    use_cache_dir()  # its numba kernels are then compiled once per machine, not once per test run
    return pytest.importorskip("librosa")
