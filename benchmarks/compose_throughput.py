"""Composition throughput of ``dance compose``: frames of dance written per second for 1, 4 and 16
streams (samples of one song generated in one batch), end to end: the song's features, generation,
decoding, grounding and the files written (the model is loaded once, outside the timing). Then
``--songs`` songs (the fixtures, cut to ``--seconds`` minus 0, 1, 2, ... s) × 1 sample, composed one
after another (per song) and together in one batch (``compose.batch_songs``).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/compose_throughput.py [--recipe default]
        [--music SONG] [--seconds 10] [--streams 1 4 16] [--songs 4] [--repeats 3]

Prints one JSON object per configuration (the median of ``--repeats`` runs) and a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import torch

from dance_core.api import Composer, load_recipe

FIXTURE = "/work/shared/fixtures/audio/vibe_ace.ogg"
FIXTURES = "/work/shared/fixtures/audio"


def timings(frames: int, wall: float, t_features: float, t_generate: float, end: float, cpu: float) -> dict:
    """One timed composition's figures from its clock readings (start, features done, generation done, end)."""
    return {
        "frames": frames,
        "wall_s": end - wall,
        "features_s": t_features - wall,
        "generate_s": t_generate - t_features,
        "write_s": end - t_generate,
        "cpu_s": cpu,
        "frames_per_s": frames / (end - wall),
        "generate_frames_per_s": frames / (t_generate - t_features),
    }


def compose_once(composer: Composer, song_path: str, out: Path) -> dict:
    """One song composed with the recipe's ``compose.samples`` streams, timed phase by phase."""
    c = composer.recipe.compose
    seed = composer.seed("rest")
    wall, cpu = time.perf_counter(), time.process_time()
    song = composer.song(song_path, texts=[])
    t_features = time.perf_counter()
    motion = composer.generate(song, seed)
    t_generate = time.perf_counter()
    composer.write(song, motion, out, [f"{song.name}-{k}" for k in range(c.samples)])
    end, cpu = time.perf_counter(), time.process_time() - cpu
    frames = c.samples * song.n_frames
    return timings(frames, wall, t_features, t_generate, end, cpu)


def compose_songs_once(composer: Composer, songs: list[tuple[str, float]], out: Path, batched: bool) -> dict:
    """Several songs (path, seconds) × ``compose.samples``, one after another or in one batch, timed."""
    c = composer.recipe.compose
    seed = composer.seed("rest")
    wall, cpu = time.perf_counter(), time.process_time()
    loaded = [composer.song(path, seconds, texts=[]) for path, seconds in songs]
    t_features = time.perf_counter()
    motions = (composer.generate_batch(loaded, seed) if batched
               else [composer.generate(song, seed) for song in loaded])
    t_generate = time.perf_counter()
    for song, motion in zip(loaded, motions, strict=True):
        composer.write(song, motion, out, [f"{song.name}-{k}" for k in range(c.samples)])
    end, cpu = time.perf_counter(), time.process_time() - cpu
    frames = c.samples * sum(song.n_frames for song in loaded)
    return timings(frames, wall, t_features, t_generate, end, cpu)


def measure(run, repeats: int) -> tuple[list[dict], str]:
    """A warm-up, then ``repeats`` runs; the runs and the load average range over them."""
    run()  # warm-up: JIT, caches
    load = [os.getloadavg()[0]]
    runs = []
    for _ in range(repeats):
        runs.append(run())
        load.append(os.getloadavg()[0])
    return runs, f"{min(load):.2f}-{max(load):.2f}"


def summary(runs: list[dict]) -> dict:
    """Medians of every figure, and the range of frames/s."""
    row = {key: round(statistics.median(r[key] for r in runs), 3) for key in runs[0]}
    row["frames_per_s_range"] = [round(min(r["frames_per_s"] for r in runs), 1),
                                 round(max(r["frames_per_s"] for r in runs), 1)]
    return row


def main() -> None:
    """Time every stream count and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="default")
    parser.add_argument("--music", default=FIXTURE)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--streams", type=int, nargs="*", default=[1, 4, 16])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--songs", type=int, default=4, help="songs x 1 sample, per song and batched (0: skip)")
    parser.add_argument("--format", default="npz")
    args = parser.parse_args()
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, torch {torch.__version__}, "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, load average {os.getloadavg()[0]:.2f}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for streams in args.streams:
            recipe = load_recipe(args.recipe, [f"compose.samples={streams}", f"compose.seconds={args.seconds}",
                                               f"compose.formats=[{args.format}]"])
            composer = Composer(recipe)
            device = composer.device
            runs, load = measure(partial(compose_once, composer, args.music, Path(tmp)), args.repeats)
            row = summary(runs)
            row.update(recipe=args.recipe, streams=streams, what=f"1 song x {streams}",
                       threads=torch.get_num_threads(), load=load, device=str(device))
            print(json.dumps(row), flush=True)
            rows.append(row)
        if args.songs:
            paths = sorted(str(p) for p in Path(FIXTURES).glob("*.ogg"))
            songs = [(paths[k % len(paths)], max(args.seconds - k, 1.0)) for k in range(args.songs)]
            for batched in (False, True):
                k = args.songs if batched else 1
                recipe = load_recipe(args.recipe, ["compose.samples=1", f"compose.batch_songs={k}",
                                                   f"compose.formats=[{args.format}]"])
                composer = Composer(recipe)
                device = composer.device
                runs, load = measure(partial(compose_songs_once, composer, songs, Path(tmp), batched), args.repeats)
                row = summary(runs)
                row.update(recipe=args.recipe, streams=args.songs, threads=torch.get_num_threads(), load=load,
                           what=f"{args.songs} songs x 1, " + ("one batch" if batched else "per song"),
                           device=str(device), songs=[f"{Path(p).stem}:{s:g}s" for p, s in songs])
                print(json.dumps(row), flush=True)
                rows.append(row)
    print("\n| what | frames | wall s | features s | generate s | decode+ground+write s | frames/s (all streams) "
          "| generation frames/s | frames per CPU s | load |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['what']} | {r['frames']} | {r['wall_s']:.2f} | {r['features_s']:.2f} | {r['generate_s']:.2f} "
              f"| {r['write_s']:.2f} | {r['frames_per_s']:.0f} ({r['frames_per_s_range'][0]:.0f}-"
              f"{r['frames_per_s_range'][1]:.0f}) | {r['generate_frames_per_s']:.0f} | {r['frames'] / r['cpu_s']:.0f} "
              f"| {r['load']} |")


if __name__ == "__main__":
    main()
