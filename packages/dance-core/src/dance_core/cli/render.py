"""``dance render``: a motion file to a GIF, an MP4 with music, or a self-contained HTML player.

Registered through core's ``register_commands`` hook; everything heavy is imported in ``run``.
"""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    """Add the ``render`` subcommand."""
    p = subparsers.add_parser(
        "render",
        help="render a motion file as a GIF, an MP4 with music, or an HTML player",
        description="Render a motion file (BVH, SMPL pickle, joints, keypoints...) as a stick-figure preview; "
        "the output's suffix picks the kind: .gif, .mp4 (music muxed in) or .html (self-contained player).",
    )
    p.add_argument("motion", help="motion file (any registered motion format)")
    p.add_argument("--music", help="song to play along (muxed into MP4, embedded in HTML)")
    p.add_argument("-o", "--out", action="append", required=True, help="output .gif, .mp4 or .html (repeatable)")
    p.add_argument("--size", type=int, nargs=2, default=(480, 480), metavar=("W", "H"), help="frame size in pixels")
    p.add_argument("--fps", type=float, help="preview frame rate (default: the motion's, at most 30)")
    p.add_argument("--seconds", type=float, help="render only the first SECONDS")
    p.add_argument("--no-trail", action="store_true", help="do not draw the root's trail on the floor")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Render every ``--out`` file."""
    from dance_core.data.files import read_motion_file
    from dance_core.errors import DataError
    from dance_core.registry import get_registry
    from dance_core.render.preview import render

    data = read_motion_file(args.motion, get_registry())
    motion = data.skeleton_motion
    if motion is None:
        raise DataError(f"{args.motion}: has no skeleton to draw (a plain feature file); render a BVH or pickle")
    if args.seconds:
        motion = motion.crop(0, max(1, int(round(args.seconds * motion.fps))))
    for out in args.out:
        n = render(motion, out, args.music, args.size[0], args.size[1], args.fps, not args.no_trail)
        print(f"{out} ({n} frames)")
    return 0
