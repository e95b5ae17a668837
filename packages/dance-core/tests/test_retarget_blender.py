"""Retargeted BVH files as Blender's own importer reads them (headless; skipped without ``blender`` on PATH).

``dance retarget`` runs on a 120-frame crop of the CMU fixture (cgspeed names, CMU units) onto ``dance24``
(metres), onto a Mixamo-named rig in centimetres with an A-pose (a BVH file, as a user's character would
come), and the Mixamo result back onto the CMU skeleton. Blender imports each result through
``blender/bvh_floor.py`` (the script ``test_bvh_dcc.py`` uses): it must see every frame, put the lowest bone
head or tail of each frame where our forward kinematics puts the lowest joint or End Site (within 1 cm),
and the dancer must stand on Blender's floor (median lowest point within 2 cm of 0, in metres).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.formats.bvh import BvhFormat
from dance_core.motion.motion import Motion
from dance_core.motion.rig_maps import arms_lowered, renamed
from dance_core.motion.skeletons import dance24

sys.path.insert(0, str(Path(__file__).parent))
from blender_helpers import needs_blender, run_blender, y_up  # noqa: E402

CMU = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"
FRAMES = 120
#: metres per file unit of each result: dance24 is in metres, the Mixamo rig in centimetres, and the CMU
#: skeleton in the CMU database's unit (1/0.45 inch, as its ASF files define it)
METRES = {"dance24": 1.0, "mixamo": 0.01, "back onto CMU": 0.0254 / 0.45}

pytestmark = [
    needs_blender,
    pytest.mark.skipif(not CMU.exists(), reason="../shared/fixtures/bvh/cmu_01_01.bvh not available"),
]


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> dict[str, tuple[Motion, dict, str]]:
    """Each retargeted file as we read it back, and as Blender imports it (with Blender's log)."""
    tmp = tmp_path_factory.mktemp("retarget-blender")
    take = tmp / "take.bvh"
    BvhFormat().write_motion(BvhFormat().read_motion(CMU).crop(0, FRAMES), take)
    rig = tmp / "mixamo-rig.bvh"  # a character file: one frame of its rest pose
    mixamo = renamed(arms_lowered(dance24()), "mixamo", "mixamorig:").scaled(100.0, "cm")
    BvhFormat().write_motion(Motion(mixamo, 30.0, mixamo.offsets[:1], np.tile([0, 0, 0, 1.0], (1, 24, 1))), rig)
    jobs = {"dance24": (take, "dance24"), "mixamo": (take, str(rig)), "back onto CMU": (tmp / "mixamo.bvh", str(take))}
    out = {}
    for name, (source, target) in jobs.items():
        path = tmp / f"{name.replace(' ', '-').lower()}.bvh"
        assert main(["-q", "retarget", str(source), "--to", target, "-o", str(path)]) == 0
        data, log = run_blender(path)
        out[name] = (BvhFormat().read_motion(path), data, log)
    return out


def _lowest(data: dict) -> np.ndarray:
    """Blender's lowest bone head or tail per frame (file units, Y up)."""
    return np.minimum(y_up(data["heads"])[..., 1].min(axis=1), y_up(data["tails"])[..., 1].min(axis=1))


@pytest.mark.parametrize("name", list(METRES))
def test_blender_sees_every_frame_where_our_kinematics_puts_it(imported, name):
    """Same frame count; every bone head at our joint; the lowest point per frame at ours within 1 cm."""
    motion, data, _ = imported[name]
    cm = 0.01 / METRES[name]
    expected_root = {"dance24": "Pelvis", "mixamo": "mixamorig:Hips", "back onto CMU": "Hips"}[name]
    assert motion.skeleton.names[0] == expected_root and motion.n_frames == FRAMES
    assert data["frames"] == FRAMES
    ours = motion.positions(end_sites=True)
    order = [motion.skeleton.index(b) for b in data["bones"]]
    assert np.abs(y_up(data["heads"]) - ours[:, order]).max() < cm
    assert np.abs(_lowest(data) - ours[..., 1].min(axis=1)).max() < cm


@pytest.mark.parametrize("name", [
    "dance24",
    "mixamo",
    "back onto CMU",
])
def test_the_retargeted_dancer_stands_on_blenders_floor(imported, name):
    """Median lowest point within 2 cm of Blender's floor (z = 0), in metres."""
    _, data, _ = imported[name]
    lowest_m = _lowest(data) * METRES[name]
    assert abs(np.median(lowest_m)) < 0.02, f"median lowest point {100 * np.median(lowest_m):.2f} cm"
