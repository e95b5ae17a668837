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


@needs_blender
def test_fbx_reads_back_through_blender(tmp_path):
    """``dance convert X.fbx -o Y.bvh``: Blender's FBX importer, a glb, our reader. Our own FBX comes back
    with our joints, End Sites, frame rate and frames, every joint within 1 cm (seen: 5e-6 m); a Mixamo-named
    rig in centimetres keeps its names and comes back in metres."""
    motion = _dance(dance24(), frames=45, seed=6)
    BvhFormat().write_motion(motion, tmp_path / "in.bvh")
    assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / "dance.fbx")]) == 0
    assert main(["convert", str(tmp_path / "dance.fbx"), "-o", str(tmp_path / "back.bvh")]) == 0
    ours, back = (BvhFormat().read_motion(tmp_path / f"{n}.bvh") for n in ("in", "back"))
    assert back.skeleton.names == ours.skeleton.names and sorted(back.skeleton.end_sites) == sorted(
        ours.skeleton.end_sites)
    assert back.fps == 30.0 and back.n_frames == 45
    assert np.abs(back.positions(end_sites=True) - ours.positions(end_sites=True)).max() < 0.01
    rig = renamed(arms_lowered(dance24().scaled(100.0, "cm")), "mixamo", prefix="mixamorig:")
    BvhFormat().write_motion(_dance(rig, frames=1), tmp_path / "hero.bvh")
    for out in ("hero.fbx", "hero.bvh"):
        assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / out), "--rig",
                     str(tmp_path / "hero.bvh")]) == 0
    from dance_core.formats.fbx import FbxFormat

    hero = FbxFormat().read(str(tmp_path / "hero.fbx")).skeleton_motion
    expected = BvhFormat().read_motion(tmp_path / "hero.bvh")
    assert hero.skeleton.names == expected.skeleton.names and hero.skeleton.units == "m"
    assert np.abs(hero.positions() - 0.01 * expected.positions()).max() < 0.01


@needs_blender
def test_an_fbx_without_an_armature_or_damaged_is_one_line(tmp_path, capsys):
    (tmp_path / "bad.fbx").write_bytes(b"Kaydara FBX Binary  \x00" + bytes(range(256)) * 4)
    run = subprocess.run([BLENDER, "-b", "--factory-startup", "--python-expr", "import bpy; "
                          f"bpy.ops.export_scene.fbx(filepath={str(tmp_path / 'cube.fbx')!r})"],
                         capture_output=True, text=True, timeout=180, check=False)
    assert run.returncode == 0 and (tmp_path / "cube.fbx").is_file()
    for name, said in (("bad.fbx", "FBX import failed"), ("cube.fbx", "0 armatures")):
        assert main(["convert", str(tmp_path / name), "-o", str(tmp_path / "x.bvh")]) != 0
        err = capsys.readouterr().err.strip()
        assert name in err and said in err and len(err.splitlines()) == 1, err
        assert not (tmp_path / "x.bvh").exists()


def test_reading_fbx_without_blender_is_one_line(tmp_path, monkeypatch, capsys):
    (tmp_path / "in.fbx").write_bytes(b"Kaydara FBX Binary  \x00")
    monkeypatch.setenv("PATH", str(tmp_path))  # no blender there
    assert main(["convert", str(tmp_path / "in.fbx"), "-o", str(tmp_path / "out.bvh")]) != 0
    err = capsys.readouterr().err.strip()
    assert "reading FBX needs Blender" in err and len(err.splitlines()) == 1 and not (tmp_path / "out.bvh").exists()


def test_end_bones_come_back_as_end_sites():
    """A leaf named after its parent plus ``_end`` (an End Site that went through Blender) is an End Site
    again, at its offset; the rest of the skeleton and its motion are untouched."""
    from dance_core.formats.fbx import end_bones_as_end_sites
    from dance_core.motion.motion import Motion
    from dance_core.motion.skeleton import Skeleton

    skel = Skeleton(["Hips", "Spine", "Spine_end", "Leg", "Leg_End", "Toe_end"], [-1, 0, 1, 0, 3, 3],
                    np.array([[0, 1, 0], [0, .3, 0], [0, .2, 0], [.1, -.5, 0], [0, -.4, 0], [0, 0, .1]], float))
    rot = np.random.default_rng(0).normal(size=(4, 6, 4))
    rot /= np.linalg.norm(rot, axis=-1, keepdims=True)
    motion = Motion(skel, 30.0, np.zeros((4, 3)), rot)
    out = end_bones_as_end_sites(motion)
    assert out.skeleton.names == ["Hips", "Spine", "Leg", "Toe_end"] and out.skeleton.parents == [-1, 0, 0, 2]
    assert set(out.skeleton.end_sites) == {1, 2}
    np.testing.assert_allclose(out.skeleton.end_sites[2], [0, -.4, 0])
    np.testing.assert_allclose(out.positions(end_sites=True)[:, :3], motion.positions()[:, [0, 1, 3]])
    np.testing.assert_allclose(out.positions(end_sites=True)[:, 4:], motion.positions()[:, [2, 4]], atol=1e-12)
