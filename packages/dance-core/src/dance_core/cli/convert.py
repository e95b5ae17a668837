"""``dance convert``: a motion file into another motion format (BVH, glb, NPZ, a preview...), optionally
onto another rig, at another frame rate or in other units, with the song's markers.

Registered through core's ``register_commands`` hook; everything heavy is imported in ``run``. Every
input is checked before the motion is read; the output and its markers sidecar are written as one set.
"""

from __future__ import annotations

import argparse

from dance_core.checks import bounded_number
from dance_core.delivery import UNITS, UP_AXES
from dance_core.progress import say

BLENDER_SCRIPT = ("templates", "blender", "import_dance.py.tmpl")


def add_parser(subparsers) -> None:
    """Add the ``convert`` subcommand."""
    p = subparsers.add_parser(
        "convert",
        help="convert a motion file (BVH, glb, ...) into another format, rig, frame rate or units",
        description="Convert between any readable and writable motion formats (glTF binary .glb, BVH, NPZ, "
        "HTML/GIF/MP4 previews). Optionally retarget onto your own character (--rig), resample (--fps, "
        "slerped rotations, low-pass filtered when lowering the rate), change units (--units) or the up axis "
        "(--up, BVH and NPZ) and add the "
        "song's beats, downbeats and sections (--music) to the markers a glb carries and a .markers.json "
        "sidecar holds (--markers).",
        epilog="examples:\n"
        "  dance convert dance.bvh -o dance.glb\n"
        "  dance convert dance.bvh -o dance.glb --music song.wav --markers --fps 30\n"
        "  dance convert dance.bvh -o hero.bvh --rig my_character.bvh --units cm\n"
        "  dance convert dance.bvh -o dance_z.bvh --up z     # for Z-up tools\n"
        "  dance convert dance.glb -o dance.bvh\n"
        "  dance convert --blender-script import_dance.py   # Blender: timeline markers on import",
    )
    p.add_argument("motion", nargs="?", help="motion file to convert (any registered motion format)")
    p.add_argument("-o", "--out", metavar="FILE", help="output motion file; its suffix picks the format")
    p.add_argument("--rig", metavar="RIG", help="retarget onto this rig: a motion file whose skeleton is your "
                   "character (.bvh, .glb), or dance24 / transflower21")
    p.add_argument("--rig-map", metavar="MAP", help="joint map of the rig: a preset name or a YAML file "
                   "(default: detected)")
    p.add_argument("--source-map", metavar="MAP", help="joint map of the input (default: detected)")
    p.add_argument("--fps", type=bounded_number(float, 0.0, 1000.0, above=True),
                   help="output frame rate, e.g. 24, 30 or 60 (resampled; default: the input's)")
    p.add_argument("--units", choices=sorted(UNITS), help="length units of the output (glb is always metres; "
                   "default: the input's)")
    p.add_argument("--up", choices=UP_AXES, help="up axis of the output: z for Z-up tools (bvh and npz; glb is "
                   "always Y up, as glTF 2.0 says; default: y)")
    p.add_argument("--music", metavar="SONG", help="the song the dance was made for: its beats, downbeats and "
                   "sections join the markers (needs a beat tracker: pip install dance-audio)")
    p.add_argument("--markers", action="store_true", help="also write OUT's stem + .markers.json (beats, "
                   "downbeats, sections, foot contacts, in seconds)")
    p.add_argument("--no-body", action="store_true", help="glb: the skeleton only, without the box body")
    p.add_argument("--no-ground", action="store_true", help="with --rig: keep the retargeted feet as they come")
    p.add_argument("--blender-script", metavar="FILE", help="write the Blender script that imports a .glb or "
                   ".bvh with its markers as timeline markers (blender --python FILE -- dance.glb)")
    p.set_defaults(run=run)


def _write_script(path: str, args: argparse.Namespace) -> None:
    from importlib import resources

    from dance_core.atomic import write_text
    from dance_core.checks import check_output_file

    out = check_output_file(path, "--blender-script", [".py"])
    write_text(out, resources.files("dance_core").joinpath(*BLENDER_SCRIPT).read_text(encoding="utf-8"))
    say(args, f"{out} (run: blender --python {out} -- dance.glb)")


def run(args: argparse.Namespace) -> int:
    """Check every input, then read, retarget, resample, convert units and write atomically with the markers."""
    from dance_core.atomic import OutputSet
    from dance_core.checks import check_input_file, check_output_file
    from dance_core.data.files import read_motion_file
    from dance_core.delivery import dance_markers, deliver, motion_data, plan_delivery, written_up
    from dance_core.errors import DanceError, DataError
    from dance_core.motion.markers import read_markers, sidecar_path, write_markers
    from dance_core.registry import get_registry

    if args.blender_script:
        _write_script(args.blender_script, args)
        if args.motion is None and args.out is None:
            return 0
    if args.motion is None or args.out is None:
        raise DanceError("convert: give a motion file and -o OUT (or only --blender-script FILE)")
    registry = get_registry()
    out = check_output_file(args.out, "-o", sorted(registry.suffixes("motion-format", False)))
    check_input_file(args.motion, None, "motion file")
    if args.music:
        check_input_file(args.music, "--music", "music file")
    entry = registry.for_suffix("motion-format", out.suffix, readable=False)
    # the maps, the rig (that it can be mapped) and the up axis are checked before the input is read
    delivery = plan_delivery(registry, args.rig, args.rig_map, args.source_map, not args.no_ground, args.fps,
                             args.units, up=args.up, formats=[entry.name])
    fmt = entry.build(entry.config_for({"body": False})) if args.no_body and entry.name == "glb" else entry.build()
    data = read_motion_file(args.motion, registry)
    motion = data.skeleton_motion
    if motion is None or motion.rotations is None:
        raise DataError(f"{args.motion}: converting needs a skeletal motion with joint rotations")
    motion, note = deliver(motion, delivery, args.motion)
    markers = data.meta.get("markers")
    beside = sidecar_path(args.motion)
    if markers is None and beside.is_file():
        markers = read_markers(beside)
    markers = dance_markers(motion, registry, args.music, markers)
    with OutputSet() as files:
        data = written_up(motion_data(motion, {"markers": markers, "title": out.stem}), entry.name, args.up)
        fmt.write(data, str(files.path(out)))
        if args.markers:
            write_markers(files.path(sidecar_path(out)), markers, motion.fps)
    extra = f" + {sidecar_path(out).name}" if args.markers else ""
    say(args, *([note] if note else []),
        f"{out}{extra} ({motion.n_frames} frames at {motion.fps:g} fps on {motion.skeleton.name}; "
        f"{len(markers.beats)} beats, {len(markers.sections)} sections, "
        f"{sum(len(v) for v in markers.contacts.values())} foot contacts)")
    return 0

