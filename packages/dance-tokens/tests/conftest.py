"""Shared fixtures and sizes of dance-tokens' tests."""

from __future__ import annotations

import pytest
import torch

import dance_tokens.plugin


@pytest.fixture(autouse=True)
def one_thread():
    """Tiny models run fastest on one thread, and do not fight other tests for the 2 CI cores."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture
def registry(dance_plugin):
    """The registry with this source tree's ``tokens`` plugin registered."""
    return dance_plugin(dance_tokens.plugin, "tokens")


@pytest.fixture
def tiny_head():
    """Options of a tiny ``tm2d`` head: K = 32 codes, width 32, 2 decoder layers, 1 text layer."""
    return {
        "tokenizer": {"codes": 32, "code_dim": 16, "width": 32, "crop": 16},
        "prior": {"dim": 32, "layers": 2, "text_layers": 1, "heads": 4, "ffn": 64, "dropout": 0.0,
                  "vocab_size": 40, "context": 6, "radius": 3},
    }


@pytest.fixture
def tiny_encoder():
    """Options of a tiny ``tm2d-audio`` encoder."""
    return {"dim": 32, "layers": 1, "heads": 4, "ffn": 64, "dropout": 0.0, "radius": 3}
