from __future__ import annotations

import numpy as np
import pytest
from safetensors.numpy import load_file, save_file

from dance_core.cli.main import main
from dance_core.data.features import FeatureStack
from dance_core.data.stats import Standardizer
from dance_core.recipe import load_recipe


def _recipe(tmp_path):
    path = tmp_path / "r.yaml"
    path.write_text(
        "extends: core-synthetic\n"
        "features:\n  music:\n    - plugin: mel\n      n_mels: 16\n    - plugin: onset\n      n_mels: 16\n"
        "    - plugin: madmom-downbeat\n"
    )
    return load_recipe(str(path))


def test_recipe_stack_concatenates_and_standardization_round_trips(tmp_path, sample):
    recipe = _recipe(tmp_path)
    stack = FeatureStack(recipe)
    assert stack.dims() == {"music": 16 + 1 + 2}
    n = sample.n_frames(recipe.fps)
    music = stack.extract(n, sample)["music"]
    assert music.shape == (n, 19) and music.dtype == np.float32
    # statistics saved as safetensors tensors and read back standardize and invert exactly
    std = Standardizer.fit([music[: n // 2], music[n // 2 :]])
    save_file({"mean": std.mean, "std": std.std}, str(tmp_path / "stats.safetensors"))
    loaded = load_file(str(tmp_path / "stats.safetensors"))
    again = Standardizer(loaded["mean"], loaded["std"])
    z = again.apply(music)
    np.testing.assert_allclose(z.mean(axis=0), 0.0, atol=1e-4)
    np.testing.assert_allclose(again.invert(z), music, rtol=1e-5, atol=1e-4)


def test_dance_features_cli_writes_npz_and_plot(tmp_path, audio_dir, capsys):
    out, png = tmp_path / "f.npz", tmp_path / "f.png"
    code = main(
        [
            "features",
            str(audio_dir / "sample.wav"),
            "-x",
            "mel",
            "-x",
            "onset",
            "--fps",
            "20",
            "-o",
            str(out),
            "--plot",
            str(png),
        ]
    )
    assert code == 0
    with np.load(out) as f:
        assert f["mel"].shape == (57, 80) and f["onset"].shape == (57, 1) and float(f["fps"]) == 20.0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert "57 frames at 20 fps" in capsys.readouterr().out


def test_dance_features_cli_bad_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "song.ogg"
    bad.write_text("not audio")
    code = main(["features", str(bad), "-o", str(tmp_path / "f.npz")])
    err = capsys.readouterr().err.strip()
    assert code != 0 and len(err.splitlines()) == 1 and "song.ogg" in err


@pytest.mark.parametrize("name", ["mel", "onset", "madmom-downbeat", "beats", "librosa-438"])
def test_every_music_extractor_handles_silence_and_very_short_clips(registry, name):
    from dance_audio.madmom_compat import madmom_available
    from dance_core.media import Audio, FeatureInputs

    if name in ("madmom-downbeat", "beats") and not madmom_available():
        pytest.skip("the madmom extra is not installed")
    noise = 0.1 * np.random.default_rng(0).standard_normal(int(0.6 * 22050))
    for audio in (Audio(np.zeros(2 * 44100, np.float32), 44100), Audio(noise.astype(np.float32), 22050)):
        inputs = FeatureInputs(n_frames=audio.n_frames(30.0), audio=audio)
        extractor = registry.get("feature", name).build()
        feats = extractor.extract(inputs, 30.0)
        assert feats.shape == (inputs.n_frames, extractor.dim()) and np.all(np.isfinite(feats))


def test_music_extractors_run_without_torch_librosa_or_madmom(tmp_path):
    """A fresh interpreter runs every music extractor: torch, librosa, madmom and scipy's
    slow-to-import signal/ndimage/stats stay unloaded (what keeps a fresh process fast)."""
    import subprocess
    import sys
    import textwrap

    from dance_audio.madmom_compat import madmom_available

    names = ["librosa-438", "mel", "onset"] + (["madmom-downbeat", "beats"] if madmom_available() else [])
    script = textwrap.dedent(
        f"""
        import sys
        import numpy as np
        from dance_core.media import Audio, FeatureInputs
        from dance_core.registry import get_registry

        t = np.arange(3 * 22050) / 22050
        audio = Audio((0.3 * np.sin(2 * np.pi * 440 * t) * (t % 0.5 < 0.05)).astype(np.float32), 22050)
        inputs = FeatureInputs(n_frames=audio.n_frames(30.0), audio=audio)
        for name in {names!r}:
            feats = get_registry().get("feature", name).build().extract(inputs, 30.0)
            assert len(feats) == 90 and np.all(np.isfinite(feats)), name
        heavy = ("torch", "librosa", "madmom", "scipy.signal", "scipy.ndimage", "scipy.stats")
        print(sorted(m for m in heavy if m in sys.modules))
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300, cwd=tmp_path, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == "[]"
