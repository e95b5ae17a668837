"""Generation speed of dance-flow's Transflower: frames/s of ``ComposedModel.generate``.

CPU: ``transflower-small`` (the bundled model) with 1 and 2 intra-op threads, one stream and
batches of streams (samples x songs). GPU (when CUDA is available): the paper-size ``transflower``
recipe, one stream and a batch. Weights do not change the cost, so untrained models are timed when
no checkpoint is given. Prints one JSON object per configuration and a Markdown table.

    .venv/bin/python benchmarks/flow_generate.py [--frames 400] [--checkpoint PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import torch

from dance_core.api import Composer, build_model, load_recipe

MOTION_DIM = 75  # synthetic dancer: root deltas + 24 expmaps (the paper's is 67-69)
MUSIC_DIM = 83  # 80 mel + onset + 2 madmom downbeat activations


def time_generate(
    recipe_name: str, device: str, batch: int, frames: int, threads: int | None, checkpoint: str | None = None
) -> dict:
    """Frames generated per second (all streams together) after one warm-up run."""
    if threads:
        torch.set_num_threads(threads)
    recipe = load_recipe(recipe_name)
    torch.manual_seed(0)
    if checkpoint:
        composer = Composer(recipe, checkpoint, device=device)
        model = composer.model
        motion_dim, music_dim = composer.checkpoint.motion.dim, composer.stack.dims()["music"]
    else:
        motion_dim, music_dim = MOTION_DIM, MUSIC_DIM
        model = build_model(recipe, motion_dim, {"music": music_dim}).to(device).eval()
    start = model.start_frames()
    total = start + frames
    streams = {"music": torch.randn(batch, total, music_dim, device=device)}
    seed = torch.zeros(batch, start, motion_dim, device=device)
    gen = torch.Generator(device=device).manual_seed(0)
    model.generate(streams, start + 20, seed, generator=gen)  # warm-up (allocator, caches, kernels)
    if device == "cuda":
        torch.cuda.synchronize()
    wall, cpu = time.perf_counter(), time.process_time()
    model.generate(streams, total, seed, generator=gen)
    if device == "cuda":
        torch.cuda.synchronize()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {
        "recipe": recipe_name,
        "device": device,
        "threads": torch.get_num_threads() if device == "cpu" else None,
        "batch": batch,
        "frames": frames,
        "seconds": round(wall, 3),
        "frames_per_s": round(batch * frames / wall, 1),
        "frames_per_s_per_stream": round(frames / wall, 1),
        "cpu_ms_per_step": round(1000 * cpu / frames, 2),
        "params_M": round(sum(p.numel() for p in model.parameters()) / 1e6, 2),
    }


def main() -> None:
    """Run every configuration that this machine supports."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=400, help="frames generated per stream")
    parser.add_argument("--checkpoint", help="a transflower-small checkpoint (default: untrained weights)")
    args = parser.parse_args()
    print(
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, torch {torch.__version__}, "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    rows = []
    for threads in (1, 2):
        for batch in (1, 4, 16):
            rows.append(time_generate("transflower-small", "cpu", batch, args.frames, threads, args.checkpoint))
            print(json.dumps(rows[-1]), flush=True)
    if torch.cuda.is_available():
        print(f"# GPU: {torch.cuda.get_device_name()}")
        for batch in (1, 16):
            rows.append(time_generate("transflower", "cuda", batch, args.frames, None))
            print(json.dumps(rows[-1]), flush=True)
    print("\n| recipe | device | threads | streams | frames/s (all) | frames/s per stream | CPU ms/step |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['recipe']} | {r['device']} | {r['threads'] or '-'} | {r['batch']} | {r['frames_per_s']} "
            f"| {r['frames_per_s_per_stream']} | {r['cpu_ms_per_step']} |"
        )


if __name__ == "__main__":
    main()
