"""Devices, threads and seeding shared by the loops."""

from __future__ import annotations

import os
import random

import numpy as np
import torch

from dance_core.errors import DanceError


def pick_device(name: str = "auto", threads: int | None = None) -> torch.device:
    """``auto`` picks cuda, then mps, then cpu (an unavailable explicit device is an error); sets CPU threads."""
    if threads is not None:
        torch.set_num_threads(threads)
    cuda = torch.cuda.is_available()
    mps = getattr(torch.backends, "mps", None) is not None and torch.backends.mps.is_available()
    if name == "auto":
        return torch.device("cuda" if cuda else "mps" if mps else "cpu")
    if (name == "cuda" and not cuda) or (name == "mps" and not mps):
        raise DanceError(f"device {name!r} is not available on this machine (use 'auto' or 'cpu')")
    return torch.device(name)


#: below this many parameters x streams, one CPU thread generates fastest (and two fight on a busy machine)
SMALL_WORK = 20_000_000


def generation_threads(model: torch.nn.Module, batch: int, device: torch.device, threads: int | None) -> int:
    """Set and return torch's CPU threads for generation: ``threads`` when given; else one thread for
    small work (a few small-model streams: each step is a chain of tiny matrix products, where a
    second thread only adds synchronisation), else up to 4 of the machine's cores."""
    if device.type != "cpu":
        return torch.get_num_threads()
    if threads is None:
        work = sum(p.numel() for p in model.parameters()) * batch
        threads = 1 if work < SMALL_WORK else max(1, min(4, os.cpu_count() or 1))
    torch.set_num_threads(threads)
    return threads


def seed_everything(seed: int) -> None:
    """Seed Python, NumPy and torch."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
