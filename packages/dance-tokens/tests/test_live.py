"""tm2d-small live (``dance live``): tokens sampled as the music arrives; with the whole look-ahead the tokens
and frames of ``dance compose``, with the default short one a dance covering the song."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from dance_core.data.synthetic_beats import click_track
from dance_core.formats.wav import write_wav


@pytest.fixture(scope="module")
def song_path(tmp_path_factory):
    rate, path = 16000, tmp_path_factory.mktemp("live") / "song.wav"
    write_wav(path, click_track(np.arange(0, 12, 0.45), 12.0, rate, np.random.default_rng(3)), rate)
    return path


@pytest.fixture(scope="module")
def composer():
    from dance_core.api import Composer, load_recipe

    torch.set_num_threads(1)
    return Composer(load_recipe("tm2d-small"))


def live_dance(composer, song, lookahead, texts=None, chunk=1):
    """The live generator fed the song's features ``chunk`` frames at a time; its frames and the generator.
    Checks on the way that no frame goes out before the music it waits for has arrived."""
    from dance_core.live.generator import LiveGenerator

    gen = LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device, lookahead)
    if texts is not None:
        gen.texts(texts)
    frames, received = [], 0
    for lo in range(0, song.n_frames, chunk):
        gen.add({n: v[lo : lo + chunk] for n, v in song.streams.items()})
        received = min(song.n_frames, lo + chunk)
        while gen.ready():
            first = gen.t
            frames.append(gen.step())
            assert gen.newest(first) < received
    gen.end()
    while gen.ready():
        frames.append(gen.step())
    return np.concatenate(frames), gen


def offline(composer, song, monkeypatch):
    """``dance compose``'s frames of the song and the tokens behind them."""
    head, seen = composer.model.head, {}
    finish = head.finish
    monkeypatch.setattr(head, "finish", lambda m, s: [seen.setdefault("tokens", s.tokens.clone()), finish(m, s)][1])
    return composer.generate(song)[0], seen["tokens"]


def test_with_the_whole_look_ahead_live_gives_compose_s_tokens_and_frames(composer, song_path, monkeypatch):
    song = composer.song(song_path)
    frames, tokens = offline(composer, song, monkeypatch)
    live, gen = live_dance(composer, song, lookahead=10_000)
    stream = gen.stream
    assert (stream.ahead, stream.decode_ahead) == (24, 4)  # prior radius 8 + encoder 8 x 2 layers; decoder 4
    assert gen.lookahead == (24 + 4 + 1) * 8 - 1  # 7.7 s at 30 fps for a token's first frame
    assert torch.equal(stream.state.tokens, tokens)
    assert live.shape == frames.shape
    # the decoder's convolutions over a window of tokens round differently from over the whole song
    np.testing.assert_allclose(live, frames, atol=1e-4)


def test_the_default_short_look_ahead_dances_the_whole_song(composer, song_path, monkeypatch):
    song = composer.song(song_path)
    frames, tokens = offline(composer, song, monkeypatch)
    live, gen = live_dance(composer, song, lookahead=None, chunk=7)
    assert gen.lookahead == (2 + 1 + 1) * 8 - 1  # 2 tokens of music, 1 token decoded ahead: 1.03 s
    assert live.shape == frames.shape and np.isfinite(live).all()
    assert gen.stream.state.tokens.shape == tokens.shape
    # the first tokens read music the short look-ahead cuts: another dance, as much as compose's own samples differ
    assert not np.array_equal(gen.stream.state.tokens, tokens)
    again, _ = live_dance(composer, song, lookahead=None, chunk=5)
    np.testing.assert_array_equal(live, again)  # seeded: the same dance however the music arrives


def test_an_encoder_that_reads_the_whole_song_is_refused_with_one_line(composer, monkeypatch):
    from dance_core.errors import DataError
    from dance_core.live.generator import LiveGenerator

    monkeypatch.setattr(composer.model.encoder, "reach", lambda: None)  # as with radius: null (global attention)
    with pytest.raises(DataError, match=r"reads the whole song at once; it cannot dance live") as err:
        LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device)
    assert "\n" not in str(err.value)
