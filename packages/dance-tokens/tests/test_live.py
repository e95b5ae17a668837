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
    assert gen.lookahead == (0 + 4 + 1) * 8 - 1  # no music past the token, 4 tokens decoded ahead: 1.3 s
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


def live_spans(composer, *specs):
    """The spans live: parsed as commands and laid as ``LiveTexts`` lays them."""
    from dance_core.live.texts import LiveTexts, parse_command

    texts = LiveTexts(composer.stack, composer.checkpoint, composer.device)
    for spec in specs:
        texts.add(parse_command(spec, 0.0))
    return texts.spans()


def test_a_text_span_live_changes_the_tokens_from_its_start_and_equals_compose_with_it(
        composer, song_path, monkeypatch):
    from dance_core.recipe.schema import TextSpec

    span = "4-7: a person jumps"  # 30 fps, 8 frames a token: tokens 15-26 (their middle frames in 120-210)
    song = composer.song(song_path, texts=[TextSpec.parse(span)])
    frames, tokens = offline(composer, song, monkeypatch)
    live, gen = live_dance(composer, song, lookahead=10_000, texts=live_spans(composer, span))
    assert torch.equal(gen.stream.state.tokens, tokens)
    np.testing.assert_allclose(live, frames, atol=1e-4)
    plain, plain_gen = live_dance(composer, composer.song(song_path), lookahead=10_000)
    with_text, without = gen.stream.state.tokens[0], plain_gen.stream.state.tokens[0]
    assert torch.equal(with_text[:15], without[:15])  # before the span: the music-only dance
    assert not torch.equal(with_text[15:27], without[15:27])
    np.testing.assert_array_equal(live[:15 * 8 - 40], plain[:15 * 8 - 40])  # the decoder reaches 4 tokens back
    # the short look-ahead too: the span acts from its first token, nothing before it changes
    short, short_gen = live_dance(composer, song, lookahead=None, texts=live_spans(composer, span))
    short_plain, short_plain_gen = live_dance(composer, composer.song(song_path), lookahead=None)
    a, b = short_gen.stream.state.tokens[0], short_plain_gen.stream.state.tokens[0]
    assert torch.equal(a[:15], b[:15]) and not torch.equal(a[15:27], b[15:27])


def test_a_now_span_given_mid_song_acts_from_the_next_token(composer, song_path):
    from dance_core.live.generator import LiveGenerator
    from dance_core.live.texts import NOW_SECONDS, LiveTexts, parse_command

    song = composer.song(song_path)
    runs = []
    for command in (None, "now: a person jumps"):
        gen = LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device)
        texts = LiveTexts(composer.stack, composer.checkpoint, composer.device)
        for i in range(song.n_frames):
            gen.add({n: v[i : i + 1] for n, v in song.streams.items()})
            if i == 150 and command:
                now = gen.first_open()
                span = parse_command(command, now / composer.recipe.fps)
                assert (span.start, span.end) == (now / 30, now / 30 + NOW_SECONDS) and now % 8 == 0
                texts.add(span)
                gen.texts(texts.spans())
            while gen.ready():
                gen.step()
        runs.append(gen.stream.state.tokens[0])
    first = now // 8
    assert torch.equal(runs[0][:first], runs[1][:first]) and not torch.equal(runs[0][first:], runs[1][first:])


def test_dance_live_follows_text_spans_and_commands_and_a_bad_command_is_one_line(song_path):
    import json
    import os
    import subprocess
    import sys

    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "dance_core.cli.main", "live", "tm2d-small", "--input", str(song_path), "--speed",
           "4", "--output", "-", "--json", "--max-lag", "60", "--control", "-", "--text", "1-3: a person jumps"]
    run = subprocess.run(cmd, input=b"now: a person jumps\ngarbage\n\xff\xfe\nnow: never read\n", capture_output=True,
                         timeout=300, env=env)
    err = run.stderr.decode()
    assert run.returncode == 0, err
    frames = [json.loads(line) for line in run.stdout.decode().splitlines()[1:]]
    assert [f["frame"] for f in frames] == list(range(360))  # 12 s at 30 fps
    lines = [line for line in err.splitlines() if line.startswith("dance: live:")]
    assert lines == ["dance: live: text command 'garbage': live, a span needs a start and an end (START-END: TEXT, "
                     "in seconds of music) or now: TEXT (the next 4 s)",
                     "dance: live: control: a command that is not UTF-8 text; this control input is closed"]
    summary = json.loads(err[err.index("{"):])
    texts = summary["texts"]
    assert texts[0] == {"command": "1-3: a person jumps", "start": 1.0, "end": 3.0, "text": "a person jumps"}
    assert texts[1]["command"] == "now: a person jumps" and texts[1]["end"] - texts[1]["start"] == 4.0
    assert [t["error"] is not None for t in texts[2:]] == [True, True] and len(texts) == 4
    assert summary["lookahead_s"]["model"] == pytest.approx(39 / 30, abs=1e-3)
    assert summary["latency_ms_step_first"]["p50"] > 0  # the first frame of each token


def test_falling_behind_skips_whole_tokens_and_the_dance_goes_on(composer, song_path):
    from dance_core.live.generator import LiveGenerator

    song = composer.song(song_path)
    gen = LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device)
    head = 100
    gen.add({n: v[:head] for n, v in song.streams.items()})
    first = gen.step()
    behind = gen.ready()
    assert len(first) == 8 and behind == 8 * ((head // 8 - 4) - 1)  # tokens whose 4 next ones have their music
    gen.skip(behind - 1)  # the session keeps the newest: all but the last token's frames
    assert gen.t == 8 + 8 * ((behind - 1) // 8) and gen.ready() == behind - (gen.t - 8)
    tokens = gen.stream.state.tokens[0]
    # the first step sampled tokens 0-4 (its own and the 4 decoded with it); the skipped ones after hold token 4
    assert len(tokens) == gen.t // 8 > 5 and bool((tokens[5:] == tokens[4]).all())
    gen.add({n: v[head:] for n, v in song.streams.items()})
    gen.end()
    rest = []
    while gen.ready():
        rest.append(gen.step())
    rest = np.concatenate(rest)
    assert len(rest) == song.n_frames - (gen.t - len(rest)) and gen.t == song.n_frames and np.isfinite(rest).all()
