"""Shared fixtures of dance-flow's tests."""

from __future__ import annotations

import pytest
import torch


@pytest.fixture(autouse=True)
def one_thread():
    """Run each test on one intra-op thread: these models are tiny, and on a busy 2-core machine
    two spinning OpenMP threads make them many times slower. Restores the setting afterwards."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
