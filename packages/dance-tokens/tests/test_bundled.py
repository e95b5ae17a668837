"""The bundled tm2d-small composes offline from any folder, with and without text, the same way twice."""

import numpy as np

from dance_core.cli.main import main
from dance_core.data.synthetic_beats import click_track
from dance_core.formats.wav import write_wav


def test_bundled_tm2d_small_dances_to_a_song_with_a_text_span(tmp_path, monkeypatch):
    rate = 16000
    write_wav(tmp_path / "song.wav", click_track(np.arange(0, 6, 0.5), 6.0, rate, np.random.default_rng(1)), rate)
    monkeypatch.chdir(tmp_path)  # the recipe's vocabulary resolves against the recipe, not the working folder
    for out, extra in (("plain", []), ("text", ["--text", "2-4: a person jumps"]),
                       ("again", ["--text", "2-4: a person jumps"])):
        # ground=false: grounding smooths the root over a second, so it would let the span reach earlier frames
        assert main(["-q", "compose", "tm2d-small", "--music", "song.wav", "-o", out, "--format", "npz",
                     "--set", "compose.ground=false", *extra]) == 0
    plain, text, again = (np.load(tmp_path / d / "song.npz")["values"] for d in ("plain", "text", "again"))
    assert plain.shape == text.shape and np.isfinite(text).all()
    np.testing.assert_array_equal(text, again)
    assert not np.allclose(plain[60:120], text[60:120])  # 30 fps: the span is frames 60-120
    # before the span's reach (joint VQ-VAE decoding carries a token about 34 frames back): the music-only dance
    np.testing.assert_array_equal(plain[:24], text[:24])
    assert (tmp_path / "text" / "song.texts").read_text().startswith("2")
