"""Time core's loops on the core-synthetic recipe: data preparation, training, composition."""

from __future__ import annotations

import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from dance_core.api import ComposeOptions, Trainer, compose, load_recipe, write_wav
from dance_core.synth import click_track


def main() -> None:
    """Print a markdown table of the timings."""
    recipe = load_recipe("core-synthetic")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        trainer = Trainer(recipe, Path(tmp) / "run", quiet=True)
        t1 = time.perf_counter()
        result = trainer.run()
        t2 = time.perf_counter()
        steps = recipe.training.steps
        rows.append(("data preparation (12 songs × 12 s, energy features)", f"{t1 - t0:.2f} s"))
        rows.append(
            ("training, 600 steps × 64 segments", f"{t2 - t1:.2f} s ({steps * 64 / (t2 - t1):,.0f} segments/s)")
        )
        rows.append(("final validation L1 (standardized units)", f"{result.val_loss:.4f}"))
        song = Path(tmp) / "song.wav"
        write_wav(song, click_track(np.arange(0, 60, 0.5), 60.0, 22050, np.random.default_rng(0)), 22050)
        for samples in (1, 8):
            r = load_recipe("core-synthetic", [f"compose.samples={samples}"])
            t3 = time.perf_counter()
            options = ComposeOptions(music=[song], checkpoint=result.checkpoint, out_dir=Path(tmp) / "out", quiet=True)
            compose(r, options)
            t4 = time.perf_counter()
            frames = 1200 * samples
            rows.append(
                (
                    f"compose 60 s song, {samples} sample(s) (incl. features)",
                    f"{t4 - t3:.2f} s ({frames / (t4 - t3):,.0f} frames/s)",
                )
            )
    threads = torch.get_num_threads()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, torch {torch.__version__}, threads {threads}\n")
    print("| what | figure |\n|---|---|")
    for what, figure in rows:
        print(f"| {what} | {figure} |")


if __name__ == "__main__":
    main()
