"""Import a BVH (or glTF binary) file with Blender's own importer (headless) and write where it puts every bone.

Run as ``blender -b --factory-startup --python bvh_floor.py -- in.bvh out.json``; a ``.glb`` (``.fbx``) goes through
Blender's glTF (FBX) importer instead (its frame rate, the third argument, set as the scene's first, so one key
per frame lands on one Blender frame; glTF is Y up by definition). The file is read
as Y up (``axis_forward="-Z", axis_up="Y"``, Blender's defaults for BVH), so the armature stands in
Blender's Z-up world; every imported frame is evaluated and the world head and tail of each pose
bone are written in Blender's world coordinates (metres of the file, ``global_scale`` 1):
``{"frames": N, "fps": F, "up": "z", "bones": [...], "heads": [[[x, y, z], ...], ...], "tails": ...}``.
A Y-up BVH point ``(x, y, z)`` is ``(x, -z, y)`` there. Errors exit with status 1 and one line.
"""

import builtins
import json
import os
import sys

_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    """``open`` that drops the ``U`` mode flag (Blender 3.4's importer asks for ``rU``, which Python
    3.11 refuses)."""
    if isinstance(mode, str) and "U" in mode:
        mode = mode.replace("U", "") or "r"
    return _open(file, mode, *args, **kwargs)


def main(argv):
    """Import ``argv[0]``, evaluate every frame, write the JSON to ``argv[1]`` (atomically)."""
    import bpy

    if len(argv) not in (2, 3):
        raise SystemExit("usage: blender -b --factory-startup --python bvh_floor.py -- in.bvh|in.glb out.json [fps]")
    src, dst = argv[:2]
    for obj in list(bpy.data.objects):  # the factory scene's cube, camera and light
        bpy.data.objects.remove(obj, do_unlink=True)
    if src.lower().endswith(".fbx"):
        fps = float(argv[2]) if len(argv) == 3 else 24.0
        bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = round(fps), round(fps) / fps
        bpy.ops.import_scene.fbx(filepath=src)
    elif src.lower().endswith(".glb"):
        fps = float(argv[2]) if len(argv) == 3 else 24.0
        bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = round(fps), round(fps) / fps
        import numpy  # Debian's Blender 3.4 glTF importer asks for numpy.bool, which numpy 1.24 dropped

        if not hasattr(numpy, "bool"):
            numpy.bool = bool
        bpy.ops.import_scene.gltf(filepath=src)
    builtins.open = _open_without_u
    try:
        if not src.lower().endswith((".glb", ".fbx")):
            bpy.ops.import_anim.bvh(filepath=src, axis_forward="-Z", axis_up="Y", global_scale=1.0,
                                    rotate_mode="NATIVE", use_fps_scale=False, update_scene_fps=True,
                                    update_scene_duration=True, frame_start=1)
    finally:
        builtins.open = _open
    arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    keys = sorted({int(round(k.co[0])) for c in arm.animation_data.action.fcurves for k in c.keyframe_points})
    first, last = keys[0], keys[-1]
    scene = bpy.context.scene
    names = [b.name for b in arm.pose.bones]
    heads, tails = [], []
    for frame in range(first, last + 1):
        scene.frame_set(frame)
        world = arm.matrix_world
        heads.append([list(world @ b.head) for b in arm.pose.bones])
        tails.append([list(world @ b.tail) for b in arm.pose.bones])
    out = {"frames": last - first + 1, "fps": scene.render.fps / scene.render.fps_base, "up": "z",
           "bones": names, "heads": heads, "tails": tails}
    tmp = f"{dst}.tmp{os.getpid()}"
    with _open(tmp, "w", encoding="utf-8") as f:
        json.dump(out, f)
    os.replace(tmp, dst)


if __name__ == "__main__":
    try:
        main(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [])
    except SystemExit as exc:
        print(f"bvh_floor.py: {exc}", file=sys.stderr)
        sys.exit(1)
    except Exception as exc:  # noqa: BLE001 - one line for the test, whatever Blender raised
        print(f"bvh_floor.py: {type(exc).__name__}: {exc}", file=sys.stderr)
        sys.exit(1)
    sys.exit(0)
