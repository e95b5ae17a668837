"""The live beat tracker against the offline one: its forward pass (the beats the model reads live) and its
settled beats (placed with hindsight, the beats the live beat lock steers to), each song streamed in 0.1-s
blocks as ``dance live`` receives it.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/online_beats.py [--synth 8] [--seed 3000] [--lag 1.0]
        [--music SONG ...]

**Forward**: a beat wherever :class:`dance_audio.online_beats.OnlineBeats` marks one (its phase wraps), at
the tracker frame that marks it. **Settled**: each beat as :meth:`OnlineBeats.settled_beats` placed it
``--lag`` seconds after its time (the lock plays about 1 s behind the frames generated, and those 0.56 s
behind the music heard, so 1 s is what it can wait). References: the fixture songs
(``../shared/fixtures/audio/*.ogg``) against the offline flux tracker's beats (``track_beats``, the beats
the live locking is scored on), and ``--synth`` synthesized 40-s songs (``dance_core.synth.synthesize``,
song ``k`` drawn from ``default_rng(seed + k)``, 70-160 BPM) against their true beats. Scores: the beat
F-measure at ±70 ms (``beat_tracking.f_measure``) over the first 5 s, 5-20 s, after 20 s, and all from 2 s.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from beat_tracking import DEFAULT_MUSIC, f_measure

BLOCK = 0.1
WINDOWS = ((0.0, 5.0), (5.0, 20.0), (20.0, np.inf), (2.0, np.inf))


def stream(samples: np.ndarray, rate: int, lag: float) -> tuple[np.ndarray, np.ndarray]:
    """``(forward beats, settled beats)`` in seconds of one song streamed block by block."""
    from dance_audio.online_beats import OnlineBeats

    live = OnlineBeats(100.0, rate, [4], 55.0, 160.0)
    forward, settled = [], []
    block = int(round(BLOCK * rate))
    for lo in range(0, len(samples), block):
        rows = live.push(samples[lo : lo + block])
        first = live.frames - len(rows)
        forward += [(first + i) / live.fps for i in np.flatnonzero(rows[:, 0])]
        heard = min(lo + block, len(samples)) / rate
        now = live.settled_beats()
        settled += now[(now > heard - lag - BLOCK) & (now <= heard - lag)].tolist()
    return np.asarray(forward), np.asarray(settled)


def windows(found: np.ndarray, reference: np.ndarray) -> list[float]:
    """F-measure in each of :data:`WINDOWS`."""
    return [f_measure(found[(found >= lo) & (found < hi)], reference[(reference >= lo) & (reference < hi)])
            for lo, hi in WINDOWS]


def songs(music: list[Path], synth: int, seed: int):
    """``(group, name, samples, rate, reference beats)`` of the fixture and synthesized songs."""
    from dance_audio.beats import track_beats
    from dance_core import get_registry, load_audio
    from dance_core.synth import synthesize

    for path in music:
        audio = load_audio(path, get_registry())
        yield "fixture", path.stem, audio.samples, audio.rate, np.asarray(track_beats(audio).times)
    for k in range(synth):
        rng = np.random.default_rng(seed + k)
        song = synthesize(40.0, float(rng.uniform(70, 160)), 22050, rng)
        yield "synthesized", f"synth-{seed + k}", song.audio.astype(np.float32), song.rate, np.asarray(song.beats)


def main() -> None:
    """Print each song's F-measures and the means per group."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--music", nargs="+", type=Path, default=sorted(DEFAULT_MUSIC.glob("*.ogg")))
    parser.add_argument("--synth", type=int, default=8)
    parser.add_argument("--seed", type=int, default=3000)
    parser.add_argument("--lag", type=float, default=1.0)
    args = parser.parse_args()
    names = " | ".join(f"{lo:g}-{hi:g} s" for lo, hi in WINDOWS)
    print(f"| song | forward: {names} | settled ({args.lag:g} s after): {names} |")
    scores: dict[tuple[str, str], list[list[float]]] = {}
    for group, name, samples, rate, reference in songs(args.music, args.synth, args.seed):
        forward, settled = stream(np.asarray(samples, np.float32), rate, args.lag)
        f, s = windows(forward, reference), windows(settled, reference)
        scores.setdefault((group, "forward"), []).append(f)
        scores.setdefault((group, "settled"), []).append(s)
        print(f"| {name} | " + " ".join(f"{v:.2f}" for v in f) + " | " + " ".join(f"{v:.2f}" for v in s) + " |",
              flush=True)
    for (group, kind), rows in scores.items():
        print(f"mean, {len(rows)} {group} songs, {kind}: " + " ".join(f"{v:.3f}" for v in np.mean(rows, axis=0)))


if __name__ == "__main__":
    sys.exit(main())
