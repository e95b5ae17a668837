"""Write the word-tokens vocabulary of the bundled TM2D recipes: every word the synthetic dancer's texts
use (``dance_core.synth.dancer.all_texts``), most frequent first, after the four special tokens.

    .venv/bin/python packages/dance-tokens/scripts/make_vocab.py

The recipes' ``model.head.prior.vocab_size`` must be at least the number of lines it prints.
"""

from __future__ import annotations

from pathlib import Path

from dance_audio.text import Vocabulary
from dance_core.synth.dancer import all_texts

OUT = Path(__file__).resolve().parents[1] / "src" / "dance_tokens" / "recipes" / "tm2d-vocab.txt"


def main() -> None:
    """Build the vocabulary and write it."""
    vocab = Vocabulary.build(all_texts())
    vocab.save(OUT)
    print(f"{OUT}: {len(vocab)} tokens (4 special + {len(vocab) - 4} words)")


if __name__ == "__main__":
    main()
