"""Text spans as tables from the feature stack to the model: a song's ``SpanTable`` and a batch's
``TextSpans`` (each span its own row, per frame the span in force), kept through data preparation, the
feature cache, standardization, segment sampling and the composed model."""

import numpy as np
import pytest
import torch

from dance_core import SpanTable, TextSpan, TextSpans
from dance_core.media import Audio
from dance_core.protocols import MotionData

JUMP, CLAP = "a person jumps", "a person claps"


def test_a_table_keeps_every_span_with_its_frames_and_the_span_in_force():
    texts = (TextSpan(JUMP, 1.0, 2.0), TextSpan(JUMP, 2.0, 3.0), TextSpan(CLAP, 2.5, None))
    table = SpanTable.at(texts, 8, 2.0)  # frame i at i / 2 s
    assert table.frames.tolist() == [[2, 4], [4, 6], [5, 8]]
    assert table.index.tolist() == [-1, -1, 0, 0, 1, 2, 2, 2]  # adjacent spans of one sentence stay two
    rows = np.array([[1, 1], [2, 2], [3, 3]], np.float32)
    assert table.per_frame(rows)[:, 0].tolist() == [0, 0, 1, 1, 2, 3, 3, 3]  # zeros where no span is
    cropped = table.crop(3, 5)  # frames 3-4: the first two spans, renumbered from 0
    assert [s.start for s in cropped.spans] == [1.0, 2.0] and cropped.index.tolist() == [0, 1]
    assert cropped.frames.tolist() == [[0, 1], [1, 2]]
    late = table.with_features({"text": rows}).crop(5, 8)  # the second span covers frame 5, the third is in force
    assert late.index.tolist() == [1, 1, 1] and late.features["text"][:, 0].tolist() == [2, 3]
    longer = table.extend(11)
    assert longer.index.tolist()[8:] == [2, 2, 2] and longer.frames[2].tolist() == [5, 11]
    assert SpanTable.at((), 3, 2.0).crop(1, 3).index.tolist() == [-1, -1]


def test_a_batch_table_numbers_spans_row_after_row_and_crops_and_pads_like_the_streams():
    a = SpanTable.at((TextSpan(JUMP, 0.0, 2.0), TextSpan(CLAP, 2.0, 4.0)), 6, 1.0, {"text": np.eye(2, 3)})
    b = SpanTable.at((TextSpan(CLAP, 3.0, None),), 6, 1.0, {"text": np.full((1, 3), 7.0)})
    spans = TextSpans.stack([a, b, SpanTable.at((), 6, 1.0)])
    assert spans.index.tolist() == [[0, 0, 1, 1, -1, -1], [-1, -1, -1, 2, 2, 2], [-1] * 6]
    assert spans.row.tolist() == [0, 0, 1] and spans.frames.tolist() == [[0, 2], [2, 4], [3, 6]]
    assert spans.features["text"].dtype == torch.float32 and spans.features["text"][2].tolist() == [7, 7, 7]
    later = spans.crop(2)  # the first span no longer reaches the frames
    assert [s.text for s in later.spans] == [CLAP, CLAP] and later.row.tolist() == [0, 1]
    assert later.index.tolist() == [[0, 0, -1, -1], [-1, 1, 1, 1], [-1] * 4]
    assert later.frames.tolist() == [[0, 2], [1, 4]] and later.features["text"][1].tolist() == [7, 7, 7]
    padded = later.pad(2)
    assert padded.index[:, 4:].tolist() == [[-1, -1], [1, 1], [-1, -1]] and padded.frames[1].tolist() == [1, 6]
    with pytest.raises(ValueError, match="different frame counts"):
        TextSpans.stack([a, SpanTable.at((), 5, 1.0)])


@pytest.fixture
def text_recipe(tmp_path):
    pytest.importorskip("dance_audio")
    from dance_core.recipe import load_recipe

    (tmp_path / "vocab.txt").write_text("a\nperson\njumps\nclaps\n")
    return load_recipe("core-synthetic", [f"features.text=[{{plugin: word-tokens, vocab: {tmp_path / 'vocab.txt'}, "
                                          "max_words: 4}]"])


def _sources(tmp_path, cache=False):
    from dance_core.data.sources import ClipSource
    from dance_core.formats.wav import write_wav

    rate, fps = 8000, 20.0
    rng = np.random.default_rng(0)
    audio = Audio((0.1 * rng.standard_normal(rate * 3)).astype(np.float32), rate)
    path = tmp_path / "song.wav"
    write_wav(path, audio.samples, rate)
    texts = (TextSpan(JUMP, 0.5, 1.0), TextSpan(JUMP, 1.0, 1.5), TextSpan(CLAP, 2.0, None))
    meta = {"feature_cache": str(tmp_path / "cache")} if cache else {}
    motion = MotionData(rng.standard_normal((60, 4)).astype(np.float32), fps)
    return [ClipSource("song", motion, audio=None if cache else audio, audio_path=str(path), texts=texts, meta=meta)]


def test_prepared_clips_carry_their_span_table_fresh_or_from_the_feature_cache(text_recipe, tmp_path):
    from dance_core.data.features import FeatureStack
    from dance_core.data.prepare import prepare_data
    from dance_core.data.stats import NormStats
    from dance_core.registry import get_registry

    stack = FeatureStack(text_recipe)
    assert stack.text_streams() == ["text"]
    [clip] = prepare_data(text_recipe, stack, get_registry(), _sources(tmp_path)).clips
    for cached in (True, True):  # the first writes the cache, the second reads it
        [again] = prepare_data(text_recipe, stack, get_registry(), _sources(tmp_path, cache=cached)).clips
        np.testing.assert_array_equal(again.spans.index, clip.spans.index)
        np.testing.assert_array_equal(again.spans.features["text"], clip.spans.features["text"])
        np.testing.assert_array_equal(again.streams["text"], clip.streams["text"])
    table = clip.spans
    assert len(table.spans) == 3 and table.frames.tolist() == [[10, 20], [20, 30], [40, 60]]
    rows = table.features["text"]
    assert rows.shape == (3, 4) and np.array_equal(rows[0], rows[1])  # one sentence, two spans
    np.testing.assert_array_equal(clip.streams["text"], table.per_frame(rows))  # the per-frame stream
    stats = NormStats.fit([clip], stack.categorical())
    np.testing.assert_array_equal(stats.apply(clip).spans.features["text"], rows)  # ids are not standardized


def test_sampled_segments_and_the_model_hand_heads_the_spans_aligned_with_the_streams(text_recipe, tmp_path):
    from dance_core.data.features import FeatureStack
    from dance_core.data.prepare import prepare_data
    from dance_core.data.sampling import SegmentSampler
    from dance_core.registry import get_registry

    stack = FeatureStack(text_recipe)
    clips = prepare_data(text_recipe, stack, get_registry(), _sources(tmp_path)).clips
    batch = SegmentSampler(clips, 25, 6, seed=1).draw(3)
    spans, text = batch.spans, batch.streams["text"]
    assert spans.index.shape == (6, 25)
    spread = torch.cat([spans.features["text"], torch.zeros(1, 4)])[spans.index]
    assert torch.equal(spread, text)  # each frame's span row is the stream's row there
    for k in range(len(spans.spans)):
        frames = (spans.index[spans.row[k]] == k).nonzero().flatten()
        assert frames.numel() == 0 or (frames.min() >= spans.frames[k, 0] and frames.max() < spans.frames[k, 1])
