"""Live grounding against offline on the same raw frames: a bundled model's own frames (``compose``'s, not
beat-aligned) grounded frame by frame as ``dance live`` grounds them (``motion.buffered_grounding``, the 0.1-s
look-ahead), the same without its knee-keeping drop, and offline (``motion.grounding.ground``); with ``--against
FILE`` also through the ``BufferedGrounding`` of another file (e.g. an earlier revision's
``buffered_grounding.py``). Printed per variant, means over songs x seeds: skating (m/s), jerk (m/s^3), floating
(share of frames), the median knee bend (degrees) and the pelvis' vertical jerk (m/s^3).

    python scripts/live_grounding.py [--recipe tm2d-small] [--seeds 2] [--seconds 30] [--songs A.ogg B.ogg]
        [--against OLD.py]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import live as bench  # noqa: E402  benchmarks/live.py: floor_and_motion, AUDIO
from live_lock_replay import load_class  # noqa: E402  this folder's


def knee_bend(motion) -> float:
    """The median over frames of both knees' mean flexion (degrees; 0 straight), as the realism statistics
    measure it (:func:`dance_core.evaluation.realism.frame_measures`)."""
    from dance_core.evaluation.realism import frame_measures
    from dance_core.motion.body import Body

    measures = frame_measures(motion.positions(), motion.fps, Body.of(motion.skeleton.names, "grounded dance"), 1.0)
    return float(np.median(measures["knee_bend"]))


def grounded_live(grounding_class, composer, frames: np.ndarray, **options):
    """The model's normalized ``frames`` decoded and grounded one at a time as ``dance live`` does."""
    from dance_core.live.pose import PoseDecoder
    from dance_core.motion import Motion

    decoder = PoseDecoder(composer.checkpoint, composer.registry, composer.recipe.fps)
    grounding = grounding_class(decoder.skeleton, decoder.fps, 0.1, **options)
    roots, rotations = [], []
    for frame in frames:
        root, rotation, _ = decoder.decode(frame)
        out = grounding.push(root, rotation)
        if out is not None:
            roots.append(out[0])
            rotations.append(out[1])
    return Motion(decoder.skeleton, decoder.fps, np.array(roots), np.array(rotations))


def main() -> None:
    """Ground each song's dance every way and print the means."""
    import torch

    from dance_core.api import Composer, load_recipe
    from dance_core.motion.buffered_grounding import BufferedGrounding
    from dance_core.motion.grounding import ground

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="default")
    parser.add_argument("--songs", nargs="+", type=Path, default=sorted(bench.AUDIO.glob("*.ogg")))
    parser.add_argument("--seeds", type=int, default=2, help="seeds 0 .. N-1")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--against", type=Path, help="a buffered_grounding.py whose BufferedGrounding to add")
    args = parser.parse_args()
    torch.set_num_threads(1)
    variants = {"live": (BufferedGrounding, {}), "live without the drop": (BufferedGrounding, {"drop_smoothing": None})}
    if args.against:
        variants[f"live, {args.against.name}"] = (load_class(args.against, "BufferedGrounding"), {})
    rows: dict[str, list] = {}
    for song in args.songs:
        for seed in range(args.seeds):
            composer = Composer(load_recipe(args.recipe).model_copy(update={"seed": seed}))
            s = composer.song(song, args.seconds)
            frames = composer.generate(s)[0, : s.n_frames]
            raw = composer.dances(dataclasses.replace(s, beats=None), frames[None], ground=False)[0].skeleton_motion
            dances = {"offline": ground(raw)[0]}
            dances.update({name: grounded_live(cls, composer, frames, **options)
                           for name, (cls, options) in variants.items()})
            for name, motion in dances.items():
                scores = bench.floor_and_motion(motion, np.zeros(0))
                pelvis = float(np.abs(np.diff(motion.positions()[:, 0, 1], 3)).mean() * motion.fps**3)
                rows.setdefault(name, []).append((scores["skating"], scores["jerk"], scores["float"],
                                                  knee_bend(motion), pelvis))
            print(f"{song.name} seed {seed}", flush=True)
    for name, values in rows.items():
        v = np.array(values).mean(0)
        print(f"{name}: skating {v[0]:.3f} m/s, jerk {v[1]:.1f} m/s^3, floating {v[2]:.3f}, knees {v[3]:.1f} deg, "
              f"pelvis vertical jerk {v[4]:.2f} m/s^3")


if __name__ == "__main__":
    main()
