"""Write the built-in motion seeds ("motion prompts") shipped with the recipes: 3-second BVH clips
of the synthetic dancer on our default skeleton (``dance24``; dataset seed 5, not the training songs),
each inside one move.

    .venv/bin/python packages/dance-flow/scripts/make_seeds.py
"""

from __future__ import annotations

from pathlib import Path

from dance_core.formats.bvh import BvhFormat
from dance_core.synth.synthetic_dance import make_clip

OUT = Path(__file__).resolve().parents[1] / "src" / "dance_flow" / "recipes" / "seeds"
FPS = 60
# name: (clip index, start second) with 3 s of one move from there
SEEDS = {"waves": (0, 0.5), "claps": (2, 1.0), "steps": (2, 6.0), "walks": (4, 1.0)}


def main() -> None:
    """Write every seed."""
    OUT.mkdir(parents=True, exist_ok=True)
    fmt = BvhFormat(precision=4)
    for name, (index, start) in SEEDS.items():
        clip = make_clip(index, seed=5, seconds=12.0, bpm=(80.0, 140.0), rate=22050, fps=FPS)
        first = int(start * FPS)
        fmt.write_motion(clip.motion.skeleton_motion.crop(first, first + 3 * FPS), OUT / f"{name}.bvh")
        print(OUT / f"{name}.bvh")


if __name__ == "__main__":
    main()
