"""``dance retarget``: a motion file played by another rig (a BVH or any motion file whose skeleton is the
target, or a built-in skeleton by name).

Registered through core's ``register_commands`` hook; everything heavy is imported in ``run``.
"""

from __future__ import annotations

import argparse

from dance_core.checks import bounded_number

#: built-in target skeletons by name
BUILT_IN = ("dance24", "transflower21")


def add_parser(subparsers) -> None:
    """Add the ``retarget`` subcommand."""
    p = subparsers.add_parser(
        "retarget",
        help="move a motion onto another rig (any BVH skeleton, or dance24)",
        description="Retarget a motion file onto another skeleton: joint names mapped through built-in maps "
        "(SMPL/dance24, CMU, CMU Daz-friendly, Mixamo, Unreal mannequin) or a YAML map, rest-pose differences "
        "(T-pose, A-pose) handled, travel scaled by leg length, feet put on the floor and kept from skating.",
        epilog="examples:\n"
        "  dance retarget take.bvh --to dance24 -o take-dance24.bvh\n"
        "  dance retarget dance.bvh --to my_character.bvh -o dance-on-character.bvh\n"
        "  dance retarget take.bvh --to rig.bvh --target-map rig-map.yaml -o out.bvh --fps 30\n"
        "a YAML map names the rig's joint for each canonical (SMPL-24) joint:\n"
        "  preset: mixamo        # optional: start from a built-in map\n"
        "  joints: {Pelvis: root_hips, L_Knee: knee_left}",
    )
    p.add_argument("motion", help="motion file to retarget (any registered motion format)")
    p.add_argument("--to", required=True, metavar="RIG",
                   help=f"target: a motion file whose skeleton is the rig, or one of {', '.join(BUILT_IN)}")
    p.add_argument("-o", "--out", required=True, metavar="FILE", help="output motion file (e.g. .bvh)")
    p.add_argument("--source-map", metavar="MAP", help="joint map of the input: a preset name or a YAML file "
                   "(default: detected)")
    p.add_argument("--target-map", metavar="MAP", help="joint map of the target rig (default: detected)")
    p.add_argument("--fps", type=bounded_number(float, 0.0, 1000.0, above=True),
                   help="output frame rate (resampled; default: the input's)")
    p.add_argument("--no-ground", action="store_true",
                   help="keep the retargeted feet as they come (no floor contact, no skating fix)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check the inputs, maps and output, then retarget and write atomically."""
    from dance_core.checks import check_input_file, check_output_file
    from dance_core.data.files import read_motion_file
    from dance_core.delivery import is_preset, rig_skeleton
    from dance_core.errors import DataError
    from dance_core.motion.retarget import retarget, rig_frames
    from dance_core.progress import say
    from dance_core.protocols import MotionData
    from dance_core.registry import get_registry

    registry = get_registry()
    out = check_output_file(args.out, "-o", sorted(registry.suffixes("motion-format", False)))
    check_input_file(args.motion, None, "motion file")
    for option in ("source_map", "target_map"):
        spec = getattr(args, option)
        if spec is not None and not is_preset(spec):
            check_input_file(spec, f"--{option.replace('_', '-')}", "joint map")
    target = rig_skeleton(args.to, registry, "--to")
    rig_frames(target, args.target_map, args.to)  # a target that cannot be mapped fails before the input is read
    data = read_motion_file(args.motion, registry)
    motion = data.skeleton_motion
    if motion is None or motion.rotations is None:
        raise DataError(f"{args.motion}: retargeting needs a skeletal motion with joint rotations")
    result, report = retarget(motion, target, args.source_map, args.target_map, ground=not args.no_ground,
                              where=args.motion)
    if args.fps:
        result = result.resample(args.fps)
    positions = result.positions()
    channels = [f"{name}.{axis}" for name in result.skeleton.names for axis in "xyz"]
    values = positions.reshape(len(positions), -1).astype("float32")  # what a feature format writes
    entry = registry.for_suffix("motion-format", out.suffix, readable=False)
    entry.build().write(MotionData(values, result.fps, channels, {}, result), str(out))
    say(args, report.summary(), f"{out} ({result.n_frames} frames at {result.fps:g} fps on {target.name})")
    return 0
