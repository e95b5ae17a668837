"""The live figure at rest against real people standing: how much each moves when (nearly) still.

For each CMU take in ``--mocap`` (default ``../shared/mocap/cmu-dance``, read in place) the stillest
``--window`` seconds (the lowest mean joint speed; most are the take's first seconds, the dancer waiting to
begin) give: the mean joint speed and the RMS displacement of the root, the chest and the head about their
mean. The same figures of the live rest (:class:`dance_core.live.rest.RestBlend` at weight 1, with its
breathing, sway and looking about, :mod:`dance_core.motion.idle`) over ``--seconds`` on ``dance24`` and on the
CMU rig, and of the still control (the standing pose alone, as before the idle: every figure 0).

    python scripts/at_ease.py [--mocap DIR] [--window 2] [--seconds 60]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from dance_core.formats.bvh import BvhFormat
from dance_core.live.rest import RestBlend
from dance_core.motion.fk import joint_positions
from dance_core.motion.grounding import GroundingOptions, find_feet, metres_per_unit
from dance_core.motion.rig_maps import rig_map
from dance_core.motion.skeletons import dance24
from dance_core.motion.standing import standing_pose

FPS = 30.0


def stillness(positions: np.ndarray, fps: float, joints: dict[str, int]) -> tuple[float, float, float, float]:
    """Mean joint speed (m/s) and the root's, chest's and head's RMS displacement (mm) about their means."""
    speed = float(np.linalg.norm(np.diff(positions, axis=0), axis=-1).mean() * fps)

    def rms(j: int) -> float:
        q = positions[:, j] - positions[:, j].mean(0)
        return float(np.sqrt((q**2).sum(-1).mean()) * 1000)

    chest = next(joints[n] for n in ("Spine3", "Spine2", "Spine1") if n in joints)
    return speed, rms(0), rms(chest), rms(joints["Head"])


def stillest(path: Path, window: float) -> tuple[float, tuple[float, float, float, float]]:
    """The start (s) and :func:`stillness` of the take's stillest ``window`` seconds."""
    motion = BvhFormat().read_motion(path)
    skeleton = motion.skeleton
    p = motion.positions() * metres_per_unit(skeleton, find_feet(skeleton), GroundingOptions())
    step = max(1, int(round(motion.fps / FPS)))  # at the live figure's rate: the capture's jitter is not movement
    p, fps = p[::step], motion.fps / step
    n = int(round(window * fps))
    speed = np.linalg.norm(np.diff(p, axis=0), axis=-1).mean(-1)
    i = int(np.argmin(np.convolve(speed, np.ones(n) / n, "valid")))
    return i / fps, stillness(p[i : i + n + 1], fps, rig_map(skeleton).joints)


def at_rest(skeleton, seconds: float, idle: bool = True) -> tuple[float, float, float, float]:
    """:func:`stillness` of the live figure held at rest weight 1 for ``seconds`` (``idle=False``: the control)."""
    root, rotations = standing_pose(skeleton)
    blend = RestBlend(skeleton)
    if not idle:
        blend.idle = lambda t, r, q, w: (r, q)
    frames = []
    for i in range(int(seconds * FPS)):
        frames.append(blend(root, rotations, joint_positions(skeleton, root, rotations), 1.0, i / FPS)[2])
    scale = metres_per_unit(skeleton, find_feet(skeleton), GroundingOptions())
    return stillness(np.stack(frames) * scale, FPS, rig_map(skeleton).joints)


def main() -> int:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mocap", default=str(Path(__file__).resolve().parents[2] / "shared/mocap/cmu-dance"))
    parser.add_argument("--window", type=float, default=2.0)
    parser.add_argument("--seconds", type=float, default=60.0)
    args = parser.parse_args()
    takes = sorted(Path(args.mocap).glob("*.bvh"))
    head = f"{'':28s} {'joint speed m/s':>16s} {'root mm':>8s} {'chest mm':>9s} {'head mm':>8s}"
    print(head)
    rows = []
    for path in takes:
        start, row = stillest(path, args.window)
        rows.append(row)
        print(f"{path.stem + f' @ {start:.1f} s':28s} {row[0]:16.3f} {row[1]:8.1f} {row[2]:9.1f} {row[3]:8.1f}")
    if rows:
        table = np.array(rows)
        for name, value in (("real: stillest take", table[np.argmin(table[:, 0])]),
                            ("real: 25th percentile", np.percentile(table, 25, axis=0)),
                            ("real: median", np.median(table, axis=0))):
            print(f"{name:28s} {value[0]:16.3f} {value[1]:8.1f} {value[2]:9.1f} {value[3]:8.1f}")
    rigs = [("dance24", dance24())]
    if takes:
        rigs.append(("CMU rig", BvhFormat().read_motion(takes[0]).skeleton))
    for name, skeleton in rigs:
        for label, idle in (("live rest", True), ("control: still", False)):
            value = at_rest(skeleton, args.seconds, idle)
            print(f"{label + ', ' + name:28s} {value[0]:16.3f} {value[1]:8.1f} {value[2]:9.1f} {value[3]:8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
