"""DanceRevolution's local-attention encoder: peak memory and time against song length, and the
generation speed of the LSTM decoder for a 60 s song.

Every measurement runs in a fresh Python process so that the peak resident set size (``ru_maxrss``)
belongs to it alone. The dense rows swap the banded kernel for the dense ``n × n`` masked softmax,
to show what the banded one saves.

    .venv/bin/python benchmarks/rnn_encoder.py            # the tables of benchmarks/README.md
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time

FPS = 20


def rss_mb() -> float:
    """Current resident set size in MB."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def peak_mb() -> float:
    """Peak resident set size of this process in MB (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def paper_model(motion_dim: int = 50, recipe_name: str = "dancerevolution"):
    """The recipe's model on 438-d music features, in eval mode."""
    from dance_core.api import build_model, load_recipe

    return build_model(load_recipe(recipe_name), motion_dim, {"music": 438}).eval()


def measure_encoder(minutes: float, dense: bool) -> dict:
    """Encode one song of ``minutes`` at 20 fps with the paper-size encoder (inference)."""
    import torch

    import dance_rnn.banded
    import dance_rnn.encoder

    if dense:
        dance_rnn.encoder.banded_attention = lambda q, k, v, half, bias, block, dropout, training: (
            dance_rnn.banded.dense_banded_attention(q, k, v, half, bias)
        )
    torch.manual_seed(0)
    encoder = paper_model().encoder
    n = int(minutes * 60 * FPS)
    music = torch.randn(1, n, 438)
    with torch.inference_mode():
        encoder(None, {"music": music[:, :200]})  # warm-up
        before = rss_mb()
        start = time.perf_counter()
        out = encoder(None, {"music": music})
        seconds = time.perf_counter() - start
    assert out.shape == (1, n, 1024)
    return {"minutes": minutes, "frames": n, "dense": dense, "seconds": seconds, "peak_mb": peak_mb() - before}


def measure_generation(recipe_name: str, seconds: float, threads: int) -> dict:
    """Generate one dance for ``seconds`` of music (encoder once, then frame-by-frame LSTM)."""
    import torch

    from dance_core.api import load_recipe

    torch.set_num_threads(threads)

    recipe = load_recipe(recipe_name)
    fps = recipe.fps
    torch.manual_seed(0)
    model = paper_model(50, recipe_name)
    n = int(seconds * fps)
    music = torch.randn(1, n, 438)
    seed = torch.zeros(1, 1, 50)
    model.generate({"music": music[:, :50]}, 50, seed)  # warm-up
    start = time.perf_counter()
    out = model.generate({"music": music}, n, seed, generator=torch.Generator().manual_seed(0))
    took = time.perf_counter() - start
    assert out.shape == (1, n, 50)
    return {
        "recipe": recipe_name,
        "fps": fps,
        "frames": n,
        "seconds": took,
        "realtime": seconds / took,
        "threads": threads,
    }


def child(args: list[str]) -> dict:
    """Run one measurement in a fresh interpreter and return its JSON."""
    out = subprocess.run([sys.executable, __file__, "--child", *args], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    """Print the README tables."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("--dense-minutes", type=float, nargs="*", default=[1.0, 2.5])
    args = parser.parse_args()
    if args.child:
        kind, *rest = args.child
        if kind == "encoder":
            print(json.dumps(measure_encoder(float(rest[0]), rest[1] == "dense")))
        else:
            print(json.dumps(measure_generation(rest[0], float(rest[1]), int(rest[2]))))
        return
    import torch

    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPU cores, "
        f"torch {torch.__version__} ({torch.get_num_threads()} threads), CPU only\n"
    )
    print("| song | frames (20 fps) | attention | time (s) | peak memory (MB) | MB per minute |")
    print("|---|---|---|---|---|---|")
    for minutes in (1.0, 5.0, 20.0):
        r = child(["encoder", str(minutes), "banded"])
        print(
            f"| {minutes:g} min | {r['frames']} | banded k=100 | {r['seconds']:.2f} | {r['peak_mb']:.0f} | "
            f"{r['peak_mb'] / minutes:.0f} |"
        )
    for minutes in args.dense_minutes:
        r = child(["encoder", str(minutes), "dense"])
        print(
            f"| {minutes:g} min | {r['frames']} | dense n×n mask | {r['seconds']:.2f} | {r['peak_mb']:.0f} | "
            f"{r['peak_mb'] / minutes:.0f} |"
        )
    print("\n| recipe | 60 s song | torch threads | time (s) | × real time |")
    print("|---|---|---|---|---|")
    for name in ("dancerevolution-small", "dancerevolution"):
        for threads in (1, 2):
            r = child(["generate", name, "60", str(threads)])
            print(
                f"| {name} | {r['frames']} frames at {r['fps']:g} fps | {threads} | {r['seconds']:.2f} | "
                f"{r['realtime']:.1f} |"
            )


if __name__ == "__main__":
    main()
