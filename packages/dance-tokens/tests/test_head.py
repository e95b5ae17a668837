"""The tm2d head and tm2d-audio encoder: core's contract checks, both training stages and branches, and
generation with late fusion (music-only before a text span, bit for bit; the text inside it; each span
its own run, adjacent spans with one sentence included)."""

import numpy as np
import pytest
import torch

from dance_core import RecipeError, SongInputs, SpanTable, TextSpan, TextSpans, TrainContext, Window
from dance_core.testing import check_encoder, check_head

SONG = Window(0, None, 0)


def spans_of(frames, *rows, width=5):
    """A batch's text spans over ``frames`` frames: per batch row, ``(start, end, ids)`` spans in frames
    (at 1 fps a span's seconds are its frames), the ids as the ``text`` stream's row of the span."""
    tables = []
    for row in rows:
        texts = [TextSpan(" ".join(map(str, ids)), start, end) for start, end, ids in row]
        ids = np.array([ids for _, _, ids in row], np.float32).reshape(len(row), width)
        tables.append(SpanTable.at(texts, frames, 1.0, {"text": ids}))
    return TextSpans.stack(tables)


def test_head_and_encoder_pass_the_contract_checks(registry, tiny_head, tiny_encoder):
    head = check_head("tm2d", tiny_head, window=SONG, length=32, motion_dim=6, latent_dim=16,
                      cond_dims={"music": 5, "text": 5})  # the head reads its text stream from the model's streams
    assert (head.frames, head.keep, head.history_frames, head.latent_tokens) == (8, 8, 0, None)
    check_head("tm2d", {**tiny_head, "text_stream": None}, window=SONG, length=16)
    encoder = check_encoder("tm2d-audio", tiny_encoder, cond_dims={"music": 5, "beat": 2, "text": 4}, frames=37)
    assert encoder.streams == ["beat", "music"]  # the text stream is the head's
    assert encoder.window.song_level and encoder.out_dim == 32


def test_audio_encoder_works_at_the_token_rate(registry, tiny_encoder):
    from dance_core import EncoderContext

    encoder = registry.create("encoder", "tm2d-audio", tiny_encoder, EncoderContext(6, {"music": 3})).eval()
    music = torch.randn(2, 8 * 5 + 3, 3)
    with torch.no_grad():
        latent = encoder(None, {"music": music})
        assert latent.shape == (2, 43, 32)
        tokens = latent[:, ::8]
        assert torch.equal(latent, tokens.repeat_interleave(8, dim=1)[:, :43])  # one vector per token's frames
        nudged = music.clone()
        nudged[:, 13] += 1.0  # frame 5 of token 1: the mean over the token's frames sees it
        assert not torch.equal(encoder(None, {"music": nudged})[:, 8], latent[:, 8])
    first = registry.create("encoder", "tm2d-audio", {**tiny_encoder, "pool": "first"}, EncoderContext(6, {"music": 3}))
    with torch.no_grad():
        assert torch.equal(first.eval()(None, {"music": nudged}), first(None, {"music": music}))  # every 8th frame


def test_stack_pool_keeps_the_frame_a_beat_falls_on(registry, tiny_encoder):
    from dance_core import EncoderContext
    from dance_tokens.rate import to_tokens

    music = torch.randn(2, 8 * 5 + 3, 3)
    stacked = to_tokens(music, 8, "stack")
    assert stacked.shape == (2, 6, 24)
    assert torch.equal(stacked[:, 1].reshape(2, 8, 3), music[:, 8:16])  # the token's frames in time order
    assert torch.equal(stacked[:, 5].reshape(2, 8, 3)[:, 3:], music[:, 42:43].expand(2, 5, 3))  # last frame repeated
    # a beat on frame 1 or frame 6 of a token has the same mean but not the same stack
    early, late = torch.zeros(1, 8, 1), torch.zeros(1, 8, 1)
    early[0, 1], late[0, 6] = 1.0, 1.0
    assert torch.equal(to_tokens(early, 8), to_tokens(late, 8))
    assert not torch.equal(to_tokens(early, 8, "stack"), to_tokens(late, 8, "stack"))
    options = {**tiny_encoder, "pool": "stack"}
    encoder = registry.create("encoder", "tm2d-audio", options, EncoderContext(6, {"music": 3}))
    assert encoder.embed.in_features == 24
    with torch.no_grad():
        beats = torch.zeros(1, 16, 3)
        beats[0, 1] = 1.0
        moved = torch.zeros(1, 16, 3)
        moved[0, 6] = 1.0
        assert not torch.allclose(encoder.eval()(None, {"music": beats}), encoder(None, {"music": moved}))


def test_defaults_are_the_papers(registry):
    head = registry.create("head", "tm2d", {}, _context())
    c = head.config
    assert (c.tokenizer.downsample, c.tokenizer.codes, c.tokenizer.crop, c.tokenizer.beta) == (8, 1024, 64, 0.25)
    assert (c.prior.dim, c.prior.layers, c.prior.text_layers, c.prior.heads) == (512, 6, 6, 8)
    assert (c.top_k, c.fusion, c.ramp, c.tokenizer.restart_after) == (100, 0.8, 0.2, None)


def _context(latent_dim=16, window=SONG):
    from dance_core import HeadContext

    return HeadContext(motion_dim=6, latent_dim=latent_dim, latent_tokens=None, window=window)


def test_build_refuses_a_windowed_encoder_and_a_missing_text_stream(registry, tiny_head):
    with pytest.raises(Exception, match="needs a song-level encoder"):
        registry.create("head", "tm2d", tiny_head, _context(window=Window(4, 4, 2)))
    from dance_tokens.head import build

    config = registry.get("head", "tm2d").config_for(tiny_head)
    with pytest.raises(ValueError, match="no stream 'text'.*text_stream: null"):
        build(config, motion_dim=6, latent_dim=16, window=SONG, cond_dims={"music": 5})
    head = registry.create("head", "tm2d", tiny_head, _context())
    no_rows = TextSpans.stack([SpanTable.at((), 16, 1.0)] * 2)  # a text stream of extractors without span rows
    ctx = TrainContext(0, 0, "prior", generator=torch.Generator().manual_seed(0), spans=no_rows)
    with pytest.raises(RecipeError, match=r"model.head.text_stream: 'text' is not a text stream \(text streams: none"):
        head.loss(torch.randn(2, 16, 16), torch.randn(2, 16, 6), torch.zeros(2, 0, 6), ctx)


def test_tokenizer_stage_trains_the_vqvae_on_crops_and_reports_usage(registry, tiny_head):
    head = registry.create("head", "tm2d", tiny_head, _context())
    ctx = TrainContext(0, 0, "tokenizer", generator=torch.Generator().manual_seed(0))
    out = head.loss(torch.randn(3, 40, 16), torch.randn(3, 40, 6), torch.zeros(3, 0, 6), ctx)
    assert {"loss", "recon", "usage", "perplexity"} <= set(out)
    out["loss"].backward()
    assert all(p.grad is None for p in head.prior.parameters())
    assert any(p.grad is not None for p in head.tokenizer.parameters())
    with pytest.raises(RecipeError, match=r"data.segment_frames \(8\) is shorter than model.head.tokenizer.crop"):
        head.loss(torch.randn(3, 8, 16), torch.randn(3, 8, 6), torch.zeros(3, 0, 6), ctx)


def test_prior_stage_trains_both_branches_in_one_batch(registry, tiny_head):
    head = registry.create("head", "tm2d", tiny_head, _context())
    # sample 2 holds a sentence for most of its frames, sample 3 for all of them
    spans = spans_of(32, [], [], [(3, 30, [1, 7, 9, 2, 0])], [(0, 32, [1, 8, 2, 0, 0])])
    latent = torch.randn(4, 32, 16, requires_grad=True)
    ctx = TrainContext(0, 0, "prior", generator=torch.Generator().manual_seed(0), spans=spans)
    out = head.loss(latent, torch.randn(4, 32, 6), torch.zeros(4, 0, 6), ctx)
    assert {"loss", "accuracy", "ce_music", "ce_text"} <= set(out)
    out["loss"].backward()
    assert latent.grad[:2].abs().sum() > 0 and latent.grad[2:].abs().sum() == 0  # music rows read the audio
    assert all(p.grad is None for p in head.tokenizer.parameters())  # the VQ-VAE is frozen here
    assert head.prior.text.embed.weight.grad[[7, 8, 9]].abs().sum() > 0
    sentences, has = head.sentences(spans, 4, torch.device("cpu"))
    assert has.tolist() == [False, False, True, True] and sentences[2].tolist() == [1, 7, 9, 2, 0]
    ctx.spans = spans_of(32, [(0, 1, [0, 40, 0, 0, 0])], [], [], [])
    with pytest.raises(RecipeError, match=r"vocab_size \(40\) is too small for word id 40"):
        head.loss(latent, torch.randn(4, 32, 6), torch.zeros(4, 0, 6), ctx)


def test_a_sample_takes_the_sentence_in_force_over_most_of_its_frames(registry, tiny_head):
    head = registry.create("head", "tm2d", tiny_head, _context())
    jump, clap = [1, 5, 2, 0, 0], [1, 6, 2, 0, 0]
    # clap is the longest span (12 frames), but jump is in force over 20 frames in two spans
    spans = spans_of(32, [(0, 10, jump), (10, 22, clap), (22, 32, jump)], [(0, 4, jump), (4, 32, clap)])
    sentences, has = head.sentences(spans, 2, torch.device("cpu"))
    assert has.tolist() == [True, True] and sentences.tolist() == [jump, clap]


def generate(head, latent, spans, temperature=1.0, seed=3):
    """Drive the head as core's ComposedModel.generate does: init_state, a step per token, finish."""
    n = latent.shape[1] - head.frames  # core pads the song's streams (and spans) by the head's frames
    batch = latent.shape[0]
    gen = torch.Generator().manual_seed(seed)
    out = torch.zeros(batch, n, 6)
    with torch.inference_mode():
        state = head.init_state(batch, gen, song=SongInputs(latent, {}, spans))
        t = 0
        while t < n:
            frames, state = head.step(latent[:, t : t + head.frames], out[:, :0], state, temperature, gen)
            k = min(head.keep, n - t)
            out[:, t : t + k] = frames[:, :k]
            t += k
        return head.finish(out, state), state.tokens


@pytest.fixture
def song_head(registry, tiny_head):
    torch.manual_seed(0)
    return registry.create("head", "tm2d", {**tiny_head, "top_k": 8}, _context()).eval()


def test_before_a_text_span_the_dance_is_the_music_only_dance_bit_for_bit(song_head):
    head = song_head
    frames = 8 * 30 + 5  # a last partial token
    latent = torch.randn(2, frames + 8, 16, generator=torch.Generator().manual_seed(5))
    silent = spans_of(frames + 8, [], [])
    spoken = spans_of(frames + 8, [(8 * 12, 8 * 22, [1, 7, 9, 2, 0])], [])  # tokens 12-21 of the first dance only
    plain, plain_tokens = generate(head, latent, silent)
    fused, fused_tokens = generate(head, latent, spoken)
    assert plain.shape == fused.shape == (2, frames, 6) and plain_tokens.shape == (2, 31)
    assert torch.equal(fused_tokens[1], plain_tokens[1]) and torch.equal(fused[1], plain[1])  # no text there
    assert torch.equal(fused_tokens[0, :12], plain_tokens[0, :12])  # before the span: music only, bit for bit
    assert not torch.equal(fused_tokens[0, 12:22], plain_tokens[0, 12:22])  # the text changes the span
    first = int((fused_tokens[0] != plain_tokens[0]).nonzero()[0])
    assert first >= 12
    boundary = head.tokenizer.first_frame_reached(first)
    assert torch.equal(fused[0, :boundary], plain[0, :boundary])  # frames the changed token cannot reach
    assert not torch.equal(fused[0, boundary], plain[0, boundary])  # and the first it can
    again, again_tokens = generate(head, latent, spoken)
    assert torch.equal(again, fused) and torch.equal(again_tokens, fused_tokens)  # a seed gives one dance


def test_text_branch_runs_only_where_the_text_weighs(song_head, monkeypatch):
    head = song_head
    latent = torch.randn(1, 8 * 20 + 8, 16)
    text = spans_of(8 * 20 + 8, [(8 * 5, 8 * 15, [1, 7, 2, 0, 0])])
    calls = []
    original = head.prior.hidden_text
    def counted(seq, positions, *rest):
        calls.append(int(positions[-1]))
        return original(seq, positions, *rest)

    monkeypatch.setattr(head.prior, "hidden_text", counted)
    _, tokens = generate(head, latent, text, temperature=0.0)
    assert calls == list(range(5, 15))  # the span's ten tokens, every one of them weighted
    state = head.init_state(1, None, song=SongInputs(latent, {}, text))
    assert state.span_of[0].tolist() == [-1] * 5 + [0] * 10 + [-1] * 6
    assert state.weight[0, 5:15].max() == head.config.fusion and state.weight[0, 15:].abs().sum() == 0
    music_only = head.init_state(1, None, song=SongInputs(latent, {}))  # no spans: music only
    assert music_only.weight is None


def test_adjacent_spans_with_one_sentence_stay_two_spans_each_with_its_fusion(song_head):
    head, jump = song_head, [1, 7, 2, 0, 0]
    latent = torch.randn(1, 8 * 20 + 8, 16)
    two = head.init_state(1, None, song=SongInputs(latent, {}, spans_of(8 * 20 + 8, [(40, 80, jump), (80, 120, jump)])))
    one = head.init_state(1, None, song=SongInputs(latent, {}, spans_of(8 * 20 + 8, [(40, 120, jump)])))
    assert two.span_of[0].tolist() == [-1] * 5 + [0] * 5 + [1] * 5 + [-1] * 6  # two runs, two text memories
    assert one.span_of[0].tolist() == [-1] * 5 + [0] * 10 + [-1] * 6
    from dance_tokens.fusion import fusion_weights

    rise_and_fall = fusion_weights(5, head.config.fusion, head.config.ramp)
    assert torch.equal(two.weight[0, 5:15], torch.cat([rise_and_fall, rise_and_fall]))  # falls and rises at the edge
    assert two.weight[0, 9] < head.config.fusion and one.weight[0, 9] == head.config.fusion
    assert torch.equal(two.text_memory[0], two.text_memory[1])  # the same sentence, encoded for each span


def test_finish_decodes_all_tokens_jointly(song_head):
    latent = torch.randn(1, 8 * 6 + 8, 16)
    motion, tokens = generate(song_head, latent, spans_of(8 * 6 + 8, []))
    with torch.no_grad():
        torch.testing.assert_close(motion, song_head.tokenizer.decode(tokens)[:, : 8 * 6], rtol=0, atol=0)


def test_a_missing_text_stream_fails_when_the_head_is_built(registry, tiny_head):
    from dance_core import HeadContext

    ctx = HeadContext(6, 16, None, SONG, cond_dims={"music": 5, "beat": 2})
    with pytest.raises(ValueError, match="text_stream: the features have no stream 'text'"):  # RecipeError in a recipe
        registry.create("head", "tm2d", tiny_head, ctx)
    assert registry.create("head", "tm2d", {**tiny_head, "text_stream": None}, ctx) is not None
