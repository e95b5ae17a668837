"""Running Blender's own BVH importer headless for the tests (``blender/bvh_floor.py``), shared by the
BVH and retargeting tests; skipped cleanly where Debian's ``blender`` is not installed."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

BLENDER = shutil.which("blender")
BLENDER_SCRIPT = Path(__file__).resolve().parent / "blender" / "bvh_floor.py"
needs_blender = pytest.mark.skipif(BLENDER is None, reason="needs Blender: `apt-get install blender` "
                                   "(make install does it when run as root)")


def run_blender(path: Path, out: Path | None = None, timeout: int = 180, fps: float | None = None) -> tuple[dict, str]:
    """Blender's import of the BVH (or glb, played at ``fps``) at ``path`` (bone heads and tails per frame,
    Z up, as JSON written to ``out``) and its log."""
    out = out or path.with_suffix(".json")
    rate = [] if fps is None else [str(fps)]
    run = subprocess.run([BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                          str(BLENDER_SCRIPT), "--", str(path), str(out), *rate],
                         capture_output=True, text=True, timeout=timeout, check=False)
    assert run.returncode == 0 and out.is_file(), f"blender failed: {(run.stderr or run.stdout)[-2000:]}"
    return json.loads(out.read_text()), run.stdout


def y_up(points: list) -> np.ndarray:
    """Blender world points (imported with axis_forward=-Z, axis_up=Y) back in the file's Y-up axes."""
    p = np.asarray(points, float)
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)
