"""``dance render``: a motion file to a GIF, an MP4 with music, or a self-contained HTML player.

Registered through core's ``register_commands`` hook; everything heavy is imported in ``run``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dance_core.checks import bounded_number
from dance_core.cli.checks import smpl_model_option

#: what ``-o`` may end in (the suffix picks the kind of preview)
SUFFIXES = (".gif", ".mp4", ".html")


def add_parser(subparsers) -> None:
    """Add the ``render`` subcommand."""
    p = subparsers.add_parser(
        "render",
        help="render a motion file as a GIF, an MP4 with music, or an HTML player",
        description="Render a motion file (BVH, SMPL pickle, joints, keypoints...) as a stick-figure preview; "
        "the output's suffix picks the kind: .gif, .mp4 (music muxed in) or .html (self-contained player).",
        epilog="examples:\n"
        "  dance render out/song.bvh --music song.ogg -o song.mp4\n"
        "  dance render out/song.bvh -o song.gif -o song.html --size 320 320 --seconds 10",
    )
    p.add_argument("motion", help="motion file (any registered motion format)")
    p.add_argument("--music", metavar="SONG", help="song to play along (muxed into MP4, embedded in HTML)")
    p.add_argument("-o", "--out", action="append", required=True, metavar="FILE",
                   help="output .gif, .mp4 or .html (repeatable)")
    p.add_argument("--size", type=bounded_number(int, 16, 8192, unit="pixels"), nargs=2, default=(480, 480),
                   metavar=("W", "H"), help="frame size in pixels, 16-8192 (GIF and MP4)")
    p.add_argument("--fps", type=bounded_number(float, 0.0, 240.0, above=True),
                   help="preview frame rate, up to 240 (default: the motion's, at most 30)")
    p.add_argument("--seconds", type=bounded_number(float, 0.0, above=True), help="render only the first SECONDS")
    p.add_argument("--no-trail", action="store_true", help="do not draw the root's trail on the floor")
    smpl_model_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check every output and input, then render every ``--out`` file (with a progress bar for GIF/MP4)."""
    from dance_core.checks import check_input_file, check_output_file
    from dance_core.data.files import read_motion_file
    from dance_core.errors import DataError
    from dance_core.registry import get_registry

    for out in args.out:
        check_output_file(out, "-o", SUFFIXES)
    check_input_file(args.motion, None, "motion file")
    if args.music is not None:
        check_input_file(args.music, "--music", "music file")
    data = read_motion_file(args.motion, get_registry())
    motion = data.skeleton_motion
    if motion is None:
        raise DataError(f"{args.motion}: has no skeleton to draw (a plain feature file); render a BVH or pickle")
    if args.seconds:
        motion = motion.crop(0, max(1, int(round(args.seconds * motion.fps))))
    from dance_core.progress import say

    for out in args.out:
        n = _render(motion, Path(out), args)
        say(args, f"{out} ({n} frames)")
    return 0


def _render(motion, out: Path, args: argparse.Namespace) -> int:
    """One preview; GIF and MP4 report each frame to a progress bar (hidden by ``-q``)."""
    from dance_core.render.preview import render

    width, height = args.size
    if out.suffix.lower() == ".html":  # no frame loop: written at once
        return render(motion, out, args.music, width, height, args.fps, not args.no_trail)
    from dance_core.progress import progress_bar

    with progress_bar(args.quiet) as bar:
        task = bar.add_task(f"render {out.name}", total=None, info="") if bar else None
        progress = (lambda done, total: bar.update(task, completed=done, total=total)) if bar else None
        return render(motion, out, args.music, width, height, args.fps, not args.no_trail, progress=progress)
