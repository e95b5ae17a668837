"""FBX motion through Blender (write only): the glb we write, imported by Blender's glTF importer and
exported by its FBX exporter, headless. Needs ``blender`` on PATH (Debian's package with NumPy for its
Python: ``make blender``); without it, one line saying so before anything is written."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

from dance_core.atomic import atomic_path
from dance_core.errors import DataError
from dance_core.formats.glb import motion_to_gltf
from dance_core.formats.glb_container import pack_glb
from dance_core.protocols import MotionData

SCRIPT = ("templates", "blender", "glb_to_fbx.py.tmpl")
#: Blender's start, import and export of a long dance take seconds; this bounds a stuck one
TIMEOUT = 600


class FbxFormat:
    """The ``fbx`` motion format (write only): armature, box body and baked animation, through Blender."""

    def __init__(self, body: bool = True):
        self.body = body

    def read(self, path: str) -> MotionData:
        """FBX is written, not read: convert it to glb or BVH in your tool first."""
        raise DataError(f"{path}: fbx is written only; export glb or BVH from your tool to read it")

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Write the skeletal motion behind ``motion`` as FBX, atomically (markers stay in the glb/sidecar)."""
        blender = shutil.which("blender")
        if blender is None:
            raise DataError(f"{path}: writing FBX needs Blender on PATH (apt-get install blender python3-numpy, "
                            "or make blender); glb imports into the same tools")
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: FBX needs a skeletal motion; this motion has only feature values")
        document, binary = motion_to_gltf(motion.skeleton_motion, motion.meta.get("markers"), self.body)
        script = resources.files("dance_core").joinpath(*SCRIPT).read_text(encoding="utf-8")
        with tempfile.TemporaryDirectory(prefix="dance-fbx-") as tmp, atomic_path(path, ".fbx") as out:
            glb, run_script = Path(tmp) / "dance.glb", Path(tmp) / "glb_to_fbx.py"
            glb.write_bytes(pack_glb(document, binary))
            run_script.write_text(script, encoding="utf-8")
            try:
                run = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                                      str(run_script), "--", str(glb), str(out), str(motion.skeleton_motion.fps)],
                                     capture_output=True, text=True, timeout=TIMEOUT, check=False)
            except subprocess.TimeoutExpired:
                raise DataError(f"{path}: Blender did not finish the FBX export in {TIMEOUT} s") from None
            if run.returncode != 0 or not out.is_file() or out.stat().st_size == 0:
                tail = (run.stderr or run.stdout).strip().splitlines()[-1:] or ["no output"]
                raise DataError(f"{path}: Blender's FBX export failed: {tail[0][:300]}")


def build(config: Any = None, **_: Any) -> FbxFormat:
    """Build the ``fbx`` format."""
    return FbxFormat(getattr(config, "body", True))
