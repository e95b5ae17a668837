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
        # ground=false: grounding smooths the root over a second, so it would let the span reach earlier
        # frames; beat_align=false: the beat alignment retimes the whole dance from all its accents
        assert main(["-q", "compose", "tm2d-small", "--music", "song.wav", "-o", out, "--format", "npz",
                     "--set", "compose.ground=false", "--set", "compose.beat_align=false", *extra]) == 0
    plain, text, again = (np.load(tmp_path / d / "song.npz")["values"] for d in ("plain", "text", "again"))
    assert plain.shape == text.shape and np.isfinite(text).all()
    np.testing.assert_array_equal(text, again)
    assert not np.allclose(plain[60:120], text[60:120])  # 30 fps: the span is frames 60-120
    # before the span's reach (joint VQ-VAE decoding carries a token about 34 frames back): the music-only dance
    np.testing.assert_array_equal(plain[:24], text[:24])
    assert (tmp_path / "text" / "song.texts").read_text().startswith("2")


def test_adjacent_spans_with_one_sentence_reach_the_head_as_two_spans(tmp_path, monkeypatch):
    from dance_core.api import Composer, load_recipe
    from dance_core.recipe.schema import TextSpec

    rate = 16000
    write_wav(tmp_path / "song.wav", click_track(np.arange(0, 10, 0.5), 10.0, rate, np.random.default_rng(2)), rate)
    composer = Composer(load_recipe("tm2d-small"))
    head, states = composer.model.head, []
    init = head.init_state
    monkeypatch.setattr(head, "init_state", lambda *a, **k: states.append(init(*a, **k)) or states[-1])
    two = composer.song(tmp_path / "song.wav", texts=[TextSpec.parse("2-5: a person jumps"),
                                                       TextSpec.parse("5-8: a person jumps")])
    one = composer.song(tmp_path / "song.wav", texts=[TextSpec.parse("2-8: a person jumps")])
    assert two.spans.frames.tolist() == [[60, 150], [150, 240]] and len(one.spans.spans) == 1  # 30 fps
    dance_two, dance_one = composer.generate(two), composer.generate(one)
    state = states[0]
    # tokens of 8 frames: the first span is in force at the middles of tokens 7-18, the second at 19-29
    assert state.span_of[0, 7:19].tolist() == [0] * 12 and state.span_of[0, 19:30].tolist() == [1] * 11
    peak = head.config.fusion
    assert state.weight[0, 18] < peak and state.weight[0, 19] < peak  # the text weight falls and rises at the edge
    assert states[1].span_of[0, 7:30].tolist() == [0] * 23 and states[1].weight[0, 18] == peak
    np.testing.assert_array_equal(dance_two[:, :24], dance_one[:, :24])  # before the spans' reach
    assert not np.allclose(dance_two[:, 60:240], dance_one[:, 60:240])  # two spans are not one long span
