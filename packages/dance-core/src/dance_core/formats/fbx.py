"""FBX motion through Blender, headless. Written: the glb we write, imported by Blender's glTF importer
and exported by its FBX exporter. Read: the FBX imported by Blender's FBX importer (the scene takes its
frame rate) and exported as glb, which :mod:`dance_core.formats.glb` reads; leaf bones named after their
parent plus ``_end`` (End Sites on their way through Blender) become End Sites again. Needs ``blender``
on PATH (Debian's package with NumPy for its Python: ``make blender``); without it, one line saying so
before anything is read or written."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

from dance_core.atomic import atomic_path
from dance_core.errors import DataError
from dance_core.formats.glb import GlbFormat, motion_to_gltf, positions_data
from dance_core.formats.glb_container import pack_glb
from dance_core.motion.motion import Motion
from dance_core.motion.skeleton import Skeleton
from dance_core.protocols import MotionData

SCRIPT = ("templates", "blender", "glb_to_fbx.py.tmpl")
READ_SCRIPT = ("templates", "blender", "fbx_to_glb.py.tmpl")
#: Blender's start, import and export of a long dance take seconds; this bounds a stuck one
TIMEOUT = 600


def _blender(path: str | Path, doing: str, instead: str) -> str:
    """The ``blender`` on PATH, or one line naming ``path``, what needed it and what to do ``instead``."""
    blender = shutil.which("blender")
    if blender is None:
        raise DataError(f"{path}: {doing} FBX needs Blender on PATH (apt-get install blender python3-numpy, "
                        f"or make blender); {instead}")
    return blender


def _run_blender(blender: str, script: tuple[str, ...], args: list[str], path: str | Path, doing: str) -> None:
    """Run one of our Blender scripts headless; a failure or a stuck Blender is one line naming ``path``."""
    with tempfile.TemporaryDirectory(prefix="dance-blender-") as tmp:
        run_script = Path(tmp) / script[-1].removesuffix(".tmpl")
        run_script.write_text(resources.files("dance_core").joinpath(*script).read_text(encoding="utf-8"),
                              encoding="utf-8")
        try:
            run = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                                  str(run_script), "--", *args], capture_output=True, text=True, timeout=TIMEOUT,
                                 check=False)
        except subprocess.TimeoutExpired:
            raise DataError(f"{path}: Blender did not finish the FBX {doing} in {TIMEOUT} s") from None
    if run.returncode != 0:
        said = [line for line in (run.stderr + run.stdout).splitlines() if line.startswith("dance: ")]
        tail = said[-1:] or (run.stderr or run.stdout).strip().splitlines()[-1:] or ["no output"]
        raise DataError(f"{path}: Blender's FBX {doing} failed: {tail[0].removeprefix('dance: ')[:300]}")


def end_bones_as_end_sites(motion: Motion) -> Motion:
    """The motion with every leaf joint named after its parent plus ``_end`` (how an End Site comes back
    from Blender, which makes it a bone) turned into its parent's End Site; other joints as they are."""
    skel = motion.skeleton
    ends = [j for j in range(1, len(skel)) if not skel.children(j)
            and skel.names[j].lower() == f"{skel.names[skel.parents[j]]}_end".lower()
            and skel.parents[j] not in skel.end_sites]
    if not ends:
        return motion
    keep = [j for j in range(len(skel)) if j not in ends]
    index = {j: k for k, j in enumerate(keep)}
    end_sites = {index[j]: v for j, v in skel.end_sites.items() if j in index}
    end_sites.update({index[skel.parents[j]]: skel.offsets[j] for j in ends})
    kept = Skeleton([skel.names[j] for j in keep], [index[skel.parents[j]] if k else -1 for k, j in enumerate(keep)],
                    skel.offsets[keep], [skel.channels[j] for j in keep], end_sites, skel.units, skel.up, skel.name,
                    source=skel.source)
    return replace(motion, skeleton=kept, rotations=motion.rotations[:, keep])


class FbxFormat:
    """The ``fbx`` motion format: armature, box body and baked animation written, armature and animation
    read, through Blender."""

    def __init__(self, body: bool = True):
        self.body = body

    def read(self, path: str | Path) -> MotionData:
        """The skeletal motion in an FBX file (metres, Y up), through Blender's FBX importer and a glb: the
        file's one armature, at the file's frame rate."""
        if not Path(path).is_file():
            raise DataError(f"{path}: motion file not found")
        blender = _blender(path, "reading", "or export glb or BVH from your tool")
        with tempfile.TemporaryDirectory(prefix="dance-fbx-") as tmp:
            glb = Path(tmp) / "dance.glb"
            _run_blender(blender, READ_SCRIPT, [str(Path(path).resolve()), str(glb)], path, "import")
            if not glb.is_file():
                raise DataError(f"{path}: Blender's FBX import wrote no glb")
            motion, _ = GlbFormat().read_motion(glb)
        motion = end_bones_as_end_sites(motion)
        motion.skeleton.name, motion.skeleton.source = Path(path).stem, str(path)
        return positions_data(motion, {"path": str(path)})

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write the skeletal motion behind ``motion`` as FBX, atomically (markers stay in the glb/sidecar)."""
        blender = _blender(path, "writing", "glb imports into the same tools")
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: FBX needs a skeletal motion; this motion has only feature values")
        document, binary = motion_to_gltf(motion.skeleton_motion, motion.meta.get("markers"), self.body)
        with tempfile.TemporaryDirectory(prefix="dance-fbx-") as tmp, atomic_path(path, ".fbx") as out:
            glb = Path(tmp) / "dance.glb"
            glb.write_bytes(pack_glb(document, binary))
            _run_blender(blender, SCRIPT, [str(glb), str(out), str(motion.skeleton_motion.fps)], path, "export")
            if not out.is_file() or out.stat().st_size == 0:
                raise DataError(f"{path}: Blender's FBX export failed: it wrote no file")


def build(config: Any = None, **_: Any) -> FbxFormat:
    """Build the ``fbx`` format."""
    return FbxFormat(getattr(config, "body", True))
