"""``dance convert`` for animators: onto their own rig (``--rig``), the song's markers (``--music``,
``--markers``) and the Blender script that puts them on the timeline (run headless where Blender is)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.formats.bvh import BvhFormat
from dance_core.formats.glb import GlbFormat
from dance_core.formats.wav import write_wav
from dance_core.motion.markers import Markers, read_markers, write_markers
from dance_core.motion.retarget import retarget
from dance_core.motion.rig_maps import arms_lowered, renamed
from dance_core.motion.skeletons import dance24
from dance_core.synth.music import synthesize

sys.path.insert(0, str(Path(__file__).parent))
from blender_helpers import BLENDER, needs_blender  # noqa: E402
from test_bvh_dcc import _dance  # noqa: E402


def test_rig_puts_the_dance_on_a_mixamo_character(tmp_path):
    """An A-pose rig in centimetres with Mixamo's names: the glb carries its joints and the retarget
    engine's result."""
    motion = _dance(dance24(), frames=45, seed=4)
    rig = renamed(arms_lowered(dance24().scaled(100.0, "cm")), "mixamo", prefix="mixamorig:")
    BvhFormat().write_motion(_dance(rig, frames=1), tmp_path / "hero.bvh")
    BvhFormat().write_motion(motion, tmp_path / "dance.bvh")
    assert main(["convert", str(tmp_path / "dance.bvh"), "-o", str(tmp_path / "hero.glb"),
                 "--rig", str(tmp_path / "hero.bvh")]) == 0
    out, _ = GlbFormat().read_motion(tmp_path / "hero.glb")
    assert "mixamorig:LeftUpLeg" in out.skeleton.names and "L_Hip" not in out.skeleton.names
    source = BvhFormat().read_motion(tmp_path / "dance.bvh")
    expected, _ = retarget(source, BvhFormat().read_motion(tmp_path / "hero.bvh").skeleton, where="dance.bvh")
    order = [expected.skeleton.names.index(n) for n in out.skeleton.names]
    # the engine's result (its own tests check proportions and the floor), in metres: the rig is in cm
    assert np.abs(out.positions() - 0.01 * expected.positions()[:, order]).max() < 1e-4


@pytest.fixture(scope="module")
def song(tmp_path_factory):
    """Twelve seconds of a synthesized song at 120 bpm, steady, with its true beats."""
    root = tmp_path_factory.mktemp("song")
    s = synthesize(12.0, 120.0, 16000, np.random.default_rng(1), beats_per_bar=4, drift=0.0, swing=0.5)
    write_wav(root / "song.wav", s.audio, s.rate)
    return root / "song.wav", s


def test_music_markers_land_on_the_songs_beats(tmp_path, song):
    path, truth = song
    BvhFormat().write_motion(_dance(dance24(), frames=240, seed=1), tmp_path / "dance.bvh")  # 8 s
    assert main(["convert", str(tmp_path / "dance.bvh"), "-o", str(tmp_path / "dance.glb"), "--music", str(path),
                 "--markers"]) == 0
    side = read_markers(tmp_path / "dance.markers.json")
    inside = truth.beats[truth.beats <= 8.0]
    hits = [np.min(np.abs(np.asarray(side.beats) - t)) < 0.07 for t in inside]
    assert np.mean(hits) >= 0.8 and max(side.beats) <= 8.0
    assert set(side.downbeats) <= set(side.beats) and len(side.downbeats) >= 3
    assert side.sections and side.sections[0][1] >= 0.0 and side.sections[-1][2] <= 8.0 + 1e-6
    assert GlbFormat().read_motion(tmp_path / "dance.glb")[1].beats == side.beats  # the same in the glb


def test_markers_sidecar_refuses_bad_fields(tmp_path):
    (tmp_path / "x.markers.json").write_text(json.dumps({"beats": [0.5, -1]}))
    with pytest.raises(Exception, match=r"x.markers.json: markers.beats: -1 is not a time"):
        read_markers(tmp_path / "x.markers.json")


MARKERS = Markers([0.5, 1.0], [0.5], [("chorus", 1.2, 1.9)], {"left": [(0.1, 0.4)]})


@needs_blender
@pytest.mark.parametrize("suffix", [".glb", ".bvh"])
def test_blender_script_adds_timeline_markers(tmp_path, suffix):
    """The script we ship, in Blender headless: a glb's own markers, or a BVH's sidecar, on the timeline."""
    motion = _dance(dance24(), frames=60, seed=2)
    BvhFormat().write_motion(motion, tmp_path / "in.bvh")
    write_markers(tmp_path / "in.markers.json", MARKERS, 30.0)
    assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / f"dance{suffix}")]) == 0
    if suffix == ".bvh":
        write_markers(tmp_path / "dance.markers.json", MARKERS, 30.0)
    assert main(["convert", "--blender-script", str(tmp_path / "import_dance.py")]) == 0
    run = subprocess.run([BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                          str(tmp_path / "import_dance.py"), "--", str(tmp_path / f"dance{suffix}"), "--report",
                          str(tmp_path / "report.json")], capture_output=True, text=True, timeout=180, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    report = json.loads((tmp_path / "report.json").read_text())
    first = report["frame_start"]
    assert report["fps"] == 30 and report["frame_end"] - first == 59
    got = {(name, frame - first) for name, frame in report["markers"]}
    contacts = {("L down", 3), ("L up", 12)} if suffix == ".bvh" else set()
    assert {("beat", 15), ("beat", 30), ("bar 1", 15), ("chorus", 36)} | contacts <= got


@needs_blender
def test_fbx_through_blender_imports_with_our_frames_and_floor(tmp_path):
    """``dance convert -o X.fbx``: Blender's own FBX importer reads it back with our frame count and the
    lowest joint per frame within 1 cm of ours."""
    from blender_helpers import run_blender, y_up

    motion = _dance(dance24(), frames=45, seed=6)
    BvhFormat().write_motion(motion, tmp_path / "in.bvh")
    assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / "dance.fbx")]) == 0
    data, _ = run_blender(tmp_path / "dance.fbx", tmp_path / "fbx.json", fps=30.0)
    assert data["frames"] == motion.n_frames
    ours = BvhFormat().read_motion(tmp_path / "in.bvh").positions(end_sites=True)
    assert np.abs(y_up(data["heads"])[..., 1].min(axis=1) - ours[..., 1].min(axis=1)).max() < 0.01


def test_fbx_without_blender_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("PATH", str(tmp_path))  # no blender there
    BvhFormat().write_motion(_dance(dance24(), frames=5), tmp_path / "in.bvh")
    assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / "dance.fbx")]) != 0
    assert "needs Blender" in capsys.readouterr().err and not (tmp_path / "dance.fbx").exists()
