"""Where the live dance's beat locking goes: the same song and seed danced offline and live, each stage scored.

For each song and seed (the recipe's ``seed`` set to it), body locking (``benchmarks/live.py``'s ``locking``,
first 2 s cut, against the offline flux tracker's beats) of:

* ``offline raw`` / ``grounded`` / ``offline``: ``dance compose``'s generated frames decoded, then grounded,
  then beat-aligned (``compose.beat_align``): what ``dance compose`` writes;
* ``live-made raw`` / ``grounded`` / ``finished offline``: the frames the model made live (live features, the
  online tracker's beat stream) through the same offline steps, so the difference from ``offline`` is what
  live generation costs and the difference from ``live`` what live grounding and the live beat lock cost;
* ``live``: the live pipeline's own output (``scripts/live_simulate.py``'s ``simulate``).

    python scripts/live_locking.py [--seeds 3] [--seconds 60] [--recipe default] --songs A.ogg B.wav ...
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import live as bench  # noqa: E402  benchmarks/live.py: locking, AUDIO
from live_simulate import simulate  # noqa: E402

STAGES = ("offline raw", "offline grounded", "offline", "live-made raw", "live-made grounded",
          "live-made finished offline", "live")


def stages(composer, song: Path, seconds: float, beats: np.ndarray) -> dict[str, dict]:
    """Body locking (with its wrong-tempo control) of each stage of one song's dance."""
    from dance_core.motion.buffered_grounding import LOOKAHEAD

    fps, names = composer.recipe.fps, composer.checkpoint.motion.skeleton.names
    s = composer.song(song, seconds)
    beats = beats[beats < s.n_frames / fps]

    def finished(motion: np.ndarray, ground: bool, align: bool) -> np.ndarray:
        kept = s if align else dataclasses.replace(s, beats=None)
        return composer.dances(kept, motion, ground=ground)[0].skeleton_motion.positions()

    made: list[np.ndarray] = []
    _, frames = simulate(composer, song, LOOKAHEAD, seconds=seconds, generated=made)
    offline, live_made = composer.generate(s), np.stack(made)[None, : s.n_frames]
    out = {}
    for name, motion, ground, align in (
            ("offline raw", offline, False, False), ("offline grounded", offline, True, False),
            ("offline", offline, True, True), ("live-made raw", live_made, False, False),
            ("live-made grounded", live_made, True, False), ("live-made finished offline", live_made, True, True)):
        out[name] = bench.locking(finished(motion, ground, align), fps, names, beats, 2.0)
    out["live"] = bench.locking(np.array([f["positions"] for f in frames]), fps, names, beats, 2.0)
    return out


def main() -> None:
    """Print each song and seed's stages, then their means."""
    import torch

    from dance_audio.beats import track_beats
    from dance_core import get_registry, load_audio
    from dance_core.api import load_recipe

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--songs", nargs="+", type=Path, default=sorted(bench.AUDIO.glob("*.ogg")))
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--recipe", default="default")
    args = parser.parse_args()
    torch.set_num_threads(1)
    composers = bench.seeded(load_recipe(args.recipe), args.seeds)
    rows = []
    print("song | seed | " + " | ".join(STAGES))
    for song in args.songs:
        beats = track_beats(load_audio(song, get_registry())).times
        for seed, composer in enumerate(composers):
            row = stages(composer, song, args.seconds, beats)
            rows.append(row)
            print(f"{song.stem} | {seed} | " + " | ".join(f"{row[k]['locking']:.2f} ({row[k]['control']:.2f})"
                                                        for k in STAGES), flush=True)
    print("mean | | " + " | ".join(f"{np.mean([r[k]['locking'] for r in rows]):.3f} "
                                   f"({np.mean([r[k]['control'] for r in rows]):.3f})" for k in STAGES))


if __name__ == "__main__":
    main()
