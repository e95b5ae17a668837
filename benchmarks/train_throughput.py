"""Training throughput (segments/s) on 1 and 2 CPU ranks (gloo, DistributedDataParallel).

Each configuration trains ``core-synthetic`` (window-mlp + regression, 0.2 M parameters) and a wider
variant (hidden 1024, latent 512, 1.6 M parameters) in fresh processes started as torchrun would
(``dance_core.distributed.run_local``), one torch thread per rank; the time is the training loop's
alone (data preparation excluded). Prints a markdown table with the machine and its load average.

    .venv/bin/python benchmarks/train_throughput.py [--steps 200]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import torch

from dance_core.api import load_recipe, run_local

MODELS = {
    "core-synthetic (0.2 M)": [],
    "wide window-mlp (1.6 M)": ["model.encoder.hidden=1024", "model.encoder.dim=512", "model.head.hidden=1024"],
}


def train_rank(overrides: list[str], out: str) -> tuple[float, int]:
    """On one rank: (seconds of the training loop, steps)."""
    from dance_core.api import Trainer, barrier, rank_session

    with rank_session():
        trainer = Trainer(load_recipe("core-synthetic", overrides), Path(out), quiet=True)
        barrier()
        start = time.perf_counter()
        result = trainer.run()
        return time.perf_counter() - start, result.steps


def measure(model: list[str], ranks: int, batch: int, steps: int, threads: int) -> float:
    """Segments per second (all ranks) of one configuration."""
    overrides = [*model, f"training.steps={steps}", f"training.batch_size={batch}", "training.val_every=100000",
                 "training.checkpoint_every=100000", "training.log_every=100000", f"training.threads={threads}"]
    with tempfile.TemporaryDirectory() as tmp:
        results = run_local(train_rank, ranks, overrides, str(Path(tmp) / "run"), timeout=1200, threads=threads)
    for r in results:
        if isinstance(r, BaseException):
            raise r
    seconds = max(r[0] for r in results)
    return steps * batch * ranks / seconds


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    configs = [  # (ranks, batch per rank, threads per rank)
        (1, 64, 1),
        (1, 64, 2),
        (2, 32, 1),
        (2, 64, 1),
    ]
    load_before = os.getloadavg()
    rows = []
    for name, model in MODELS.items():
        for ranks, batch, threads in configs:
            rate = measure(model, ranks, batch, args.steps, threads)
            rows.append((name, ranks, batch, ranks * batch, threads, rate))
            print(f"{name}: {ranks} rank(s) x batch {batch}, {threads} thread(s): {rate:,.0f} segments/s",
                  file=sys.stderr)
    load_after = os.getloadavg()
    print(f"{platform.machine()}, {os.cpu_count()} cores, torch {torch.__version__}, {args.steps} steps; "
          f"load average (1/5/15 min) before {load_before[0]:.2f}/{load_before[1]:.2f}/{load_before[2]:.2f}, "
          f"after {load_after[0]:.2f}/{load_after[1]:.2f}/{load_after[2]:.2f}\n")
    print("| model | ranks | batch per rank | global batch | threads per rank | segments/s |")
    print("|---|---|---|---|---|---|")
    for name, ranks, batch, total, threads, rate in rows:
        print(f"| {name} | {ranks} | {batch} | {total} | {threads} | {rate:,.0f} |")


if __name__ == "__main__":
    main()
