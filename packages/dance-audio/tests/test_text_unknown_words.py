"""Issue 28: unknown words in --text are named in one warning line, not silently read as <unk>."""

from __future__ import annotations

import numpy as np
import pytest

from dance_audio import text as text_module
from dance_audio.text import UNK, Vocabulary, WordTokens
from dance_core import TextSpan


@pytest.fixture
def tokens(tmp_path, monkeypatch):
    monkeypatch.setattr(text_module, "_warned", set())
    path = tmp_path / "vocab.txt"
    Vocabulary(["a", "person", "jumps", "spins"]).save(path)
    return WordTokens(str(path), 8)


@pytest.mark.parametrize("given, unknown", [
    ("a person jumps", []),
    ("A PERSON spins!", []),
    ("a person zorbles", ["zorbles"]),
    ("a robot moonwalks, a person jumps", ["moonwalks", "robot"]),
    ("dansé über", ["ber", "dans"]),  # the words as the tokenizer reads them (ASCII letters)
    ("1 2 3", ["1", "2", "3"]),
])
def test_unknown_words_are_named_once(tokens, capsys, given, unknown):
    rows = tokens.span_features((TextSpan(given), TextSpan(given, 1.0, 2.0)))
    err = capsys.readouterr().err.strip().splitlines()
    ids = tokens.vocab.ids
    assert (rows[0] == ids[UNK]).sum() == len([w for w in text_module.tokenize(given) if w not in ids])
    if not unknown:
        assert err == []
        return
    assert len(err) == 1 and err[0].startswith(f"dance: warning: text {given!r}: the model does not know ")
    assert ", ".join(map(repr, unknown)) in err[0] and "(read as <unk>); its vocabulary has 4 words" in err[0]
    tokens.span_features((TextSpan(given),))
    assert capsys.readouterr().err == ""  # once per process, not once per window
    np.testing.assert_array_equal(rows[0], rows[1])
