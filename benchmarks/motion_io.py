"""Motion benchmarks: building the synthetic choreography, BVH I/O on real mocap, preview rendering.

    .venv/bin/python benchmarks/motion_io.py [--songs 200] [--seconds 60] [--jobs 2]

Prints one line per measurement (wall-clock seconds) for benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CMU = ROOT / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"


def timed(label: str, fn):
    """Run ``fn`` once and print its wall-clock time."""
    start = time.perf_counter()
    result = fn()
    print(f"{label}: {time.perf_counter() - start:.2f} s", flush=True)
    return result


def main() -> None:
    """Run every measurement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--songs", type=int, default=200)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    from dance_core import get_registry
    from dance_core.api import render, write_wav
    from dance_core.synth import make_clip, write_dataset

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    machine = platform.processor() or platform.machine()
    print(f"machine: {machine}, {cores} usable cores, python {platform.python_version()}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        timed(f"dance synth: {args.songs} songs x {args.seconds:g} s at 60 fps, {args.jobs} jobs",
              lambda: write_dataset(tmp / "synth", args.songs, 0, args.seconds, 60.0, jobs=args.jobs))
        if CMU.exists():
            fmt = get_registry().create("motion-format", "bvh")  # the BVH format at its defaults
            motion = timed("BVH read cmu_01_01 (2752 frames, 31 joints)", lambda: fmt.read_motion(CMU))
            timed("BVH write cmu_01_01", lambda: fmt.write_motion(motion, tmp / "cmu.bvh"))
            timed("forward kinematics, 2752 frames", motion.positions)
        clip = make_clip(0, seed=0, seconds=30.0, bpm=(80.0, 140.0), rate=22050, fps=20.0)
        write_wav(tmp / "song.wav", clip.audio.samples, clip.audio.rate)
        dance = clip.motion.skeleton_motion
        for suffix in ("gif", "mp4", "html"):
            timed(f"render 30 s dance to {suffix} (480x480, 20 fps)",
                  lambda s=suffix: render(dance, tmp / f"d.{s}", tmp / "song.wav"))


if __name__ == "__main__":
    main()
