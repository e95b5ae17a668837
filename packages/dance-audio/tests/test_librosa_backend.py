"""``librosa-438`` with ``backend: librosa`` (librosa's own calls) against the default ``port`` backend."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dance_audio.librosa438 import Librosa438, LibrosaBackend
from dance_core.media import Audio, FeatureInputs

# block: (first column, last column + 1, tolerance over the block's largest value), as in test_features.py
BLOCKS = {
    "mfcc": (0, 20, 1e-5),
    "delta": (20, 40, 1e-5),
    "chroma": (40, 52, 1e-5),
    "onset": (52, 53, 1e-4),
    "tempogram": (54, 438, 1e-4),
}


def _song(seconds: float = 6.0, rate: int = 22050) -> Audio:
    """A chord, clicks every half second (120 BPM) and a little noise, so no frame is silent."""
    t = np.arange(int(seconds * rate)) / rate
    y = 0.1 * sum(np.sin(2 * np.pi * f * t) for f in (220.0, 277.2, 329.6))
    n = int(0.03 * rate)
    burst = 0.8 * np.sin(2 * np.pi * 2000 * np.arange(n) / rate) * np.exp(-np.arange(n) / (0.006 * rate))
    for beat in np.arange(0.25, seconds - 0.1, 0.5):
        i = int(beat * rate)
        y[i : i + n] += burst
    y += 0.01 * np.random.default_rng(0).standard_normal(len(t))
    return Audio(y.astype(np.float32), rate)


@pytest.mark.parametrize("fps", [30.0, 15.0])  # 15 fps: 7680 Hz, six constant-Q octaves instead of seven
def test_both_backends_agree_on_a_synthesized_song(librosa, fps):
    audio = _song()
    inputs = FeatureInputs(n_frames=audio.n_frames(fps), audio=audio)
    ours = Librosa438().extract(inputs, fps)
    theirs = LibrosaBackend().extract(inputs, fps)
    assert ours.shape == theirs.shape == (inputs.n_frames, 438) and theirs.dtype == np.float32
    for name, (lo, hi, tolerance) in BLOCKS.items():
        error = np.max(np.abs(ours[:, lo:hi] - theirs[:, lo:hi])) / np.max(np.abs(theirs[:, lo:hi]))
        assert error < tolerance, (name, error)
    np.testing.assert_array_equal(ours[:, 53], theirs[:, 53])  # the same beat frames
    assert theirs[:, 53].sum() >= 6


def test_the_backend_option_builds_each_extractor(registry, librosa):
    from dance_audio.configs import Librosa438Config
    from dance_audio.librosa438 import build

    assert type(registry.get("feature", "librosa-438").build()) is Librosa438  # the default: port
    assert type(build(Librosa438Config(backend="port"))) is Librosa438
    assert isinstance(build(Librosa438Config(backend="librosa")), LibrosaBackend)
    # the values agree, so a checkpoint trained on one backend composes with the other
    assert Librosa438Config.model_fields["backend"].json_schema_extra == {"generation": True}


def test_the_librosa_backend_without_librosa_is_one_line(monkeypatch):
    from dance_audio.configs import Librosa438Config
    from dance_audio.librosa438 import build
    from dance_core.errors import PluginError

    monkeypatch.setitem(sys.modules, "librosa", None)  # as if librosa were not installed
    with pytest.raises(PluginError) as info:
        build(Librosa438Config(backend="librosa"))
    message = str(info.value)
    assert "pip install 'dance-audio[librosa]'" in message and "\n" not in message


def test_the_default_backend_imports_no_librosa(tmp_path):
    script = textwrap.dedent(
        """
        import sys
        import numpy as np
        from dance_core.media import Audio, FeatureInputs
        from dance_core.registry import get_registry

        audio = Audio(0.1 * np.random.default_rng(0).standard_normal(22050).astype(np.float32), 22050)
        extractor = get_registry().get("feature", "librosa-438").build()  # the default backend
        feats = extractor.extract(FeatureInputs(n_frames=30, audio=audio), 30.0)
        assert feats.shape == (30, 438)
        print("librosa" in sys.modules)
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300, cwd=tmp_path, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == "False"
