"""glTF binary motion (``glb``): our reader against our writer, and the real tools on what we write: the
Khronos glTF-Validator (0 errors, 0 warnings), Blender's glTF importer (frame count, lowest joint per frame
within 1 cm of ours) and three.js's GLTFLoader in headless Chromium. Each tool's test is skipped cleanly
without it (``make blender``, ``make gltf-tools``, ``make browser``)."""

import json
import struct
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.errors import DataError
from dance_core.formats.bvh import BvhFormat
from dance_core.formats.glb import GlbFormat, gltf_to_motion, motion_to_gltf
from dance_core.formats.glb_container import pack_glb, unpack_glb
from dance_core.motion.markers import Markers, read_markers
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import quat_rotate
from dance_core.motion.skeletons import dance24, transflower21

sys.path.insert(0, str(Path(__file__).parent))
from blender_helpers import needs_blender, run_blender, y_up  # noqa: E402
from gltf_helpers import needs_three, needs_validator, served, validate  # noqa: E402
from test_bvh_dcc import _dance  # noqa: E402

MARKERS = Markers([0.5, 1.0, 1.5], [0.5], [("verse", 0.0, 1.2), ("chorus", 1.2, 2.0)], {"left": [(0.1, 0.4)]})


def _write(motion: Motion, path: Path, markers: Markers | None = None, body: bool = True) -> Path:
    document, binary = motion_to_gltf(motion, markers, body)
    path.write_bytes(pack_glb(document, binary))
    return path


@pytest.fixture(scope="module")
def dance(tmp_path_factory):
    """A made-up dance on dance24 (metres), two seconds at 30 fps, and its glb with markers."""
    motion = _dance(dance24(), frames=60, seed=3)
    path = _write(motion, tmp_path_factory.mktemp("glb") / "dance.glb", MARKERS)
    return motion, path


@pytest.mark.parametrize("body", [True, False])
def test_reader_gives_back_what_the_writer_wrote(dance, tmp_path, body):
    motion, path = dance
    if not body:  # no skin then: the node tree is the skeleton
        path = _write(motion, tmp_path / "bare.glb", MARKERS, body=False)
    back, markers = GlbFormat().read_motion(path)
    assert back.skeleton.names == motion.skeleton.names and back.skeleton.parents == motion.skeleton.parents
    assert back.n_frames == motion.n_frames and back.fps == motion.fps
    assert np.abs(back.positions(end_sites=True) - motion.positions(end_sites=True)).max() < 1e-5
    assert markers.beats == MARKERS.beats and markers.sections == MARKERS.sections
    assert markers.contacts == {"left": [(0.1, 0.4)]}  # given contacts are kept, not recomputed


def test_centimetre_skeleton_is_written_in_metres(tmp_path):
    motion = _dance(transflower21(), frames=10)  # centimetres
    back, _ = GlbFormat().read_motion(_write(motion, tmp_path / "cm.glb"))
    assert back.skeleton.units == "m"
    assert np.abs(back.positions() - 0.01 * motion.positions()).max() < 1e-6


def test_foreign_rest_rotations_and_parent_transform_are_baked(dance):
    """A glb as other tools write it: joints with rest rotations (the animation's keys then are full
    local rotations) under a scaled, turned, moved node. The world positions read must not change."""
    motion, path = dance
    document, binary = unpack_glb(path.read_bytes(), "ours")
    expected = motion.positions()
    twist = np.array([0.0, np.sin(0.4), 0.0, np.cos(0.4)])
    for node in document["nodes"][: len(motion.skeleton)]:
        node["rotation"] = twist.tolist()  # rest pose only: the animation overrides every joint's rotation
    document["nodes"].append({"name": "Armature", "children": [0], "scale": [0.5] * 3,
                              "rotation": [0.0, 0.0, np.sin(0.3), np.cos(0.3)], "translation": [1.0, 2.0, 3.0]})
    document["scenes"][0]["nodes"] = [len(document["nodes"]) - 1] + document["scenes"][0]["nodes"][1:]
    back, _ = gltf_to_motion(document, binary, "foreign.glb")
    q = np.array([0.0, 0.0, np.sin(0.3), np.cos(0.3)])
    assert np.abs(back.positions() - (np.array([1.0, 2.0, 3.0]) + 0.5 * quat_rotate(q, expected))).max() < 1e-6
    # the rest pose read is the file's bind pose (the twisted rest rotations), not the unrotated one
    moved = back.skeleton.rest_positions() - back.skeleton.rest_positions()[0]
    plain = 0.5 * quat_rotate(q, motion.skeleton.rest_positions() - motion.skeleton.rest_positions()[0])
    assert np.abs(moved - plain).max() > 0.05


@pytest.mark.parametrize("damage, message", [
    (lambda b: b"GLTF" + b[4:], "not a GLB file"),
    (lambda b: b[:-8], "truncated"),
    (lambda b: b[:12] + struct.pack("<II", 4, 0x4E4F534A) + b"{no" + b[19:], "header says"),
])
def test_damaged_files_are_one_line(tmp_path, dance, damage, message):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(damage(dance[1].read_bytes()))
    with pytest.raises(DataError, match=message) as err:
        GlbFormat().read_motion(bad)
    assert "\n" not in str(err.value) and str(bad) in str(err.value)


def test_hostile_documents_are_one_line(dance):
    document, binary = unpack_glb(dance[1].read_bytes(), "ours")
    cases = [
        ({"skins": [], "scenes": [{"nodes": []}]}, "no skin and no scene nodes"),
        ({"accessors": [dict(a, count=10**9) for a in document["accessors"]]}, "run past the end"),
        ({"nodes": [dict(n, children=[0]) if i == 1 else n for i, n in enumerate(document["nodes"])]},
         "not one tree"),  # a cycle
        ({"nodes": [dict(n, children=[1]) if i == 2 else n for i, n in enumerate(document["nodes"])]},
         "is not a node of its own"),  # a joint with two parents
        ({"animations": [dict(document["animations"][0], extras={"markers": {"beats": ["x"]}})]},
         "markers.beats"),
    ]
    for change, message in cases:
        with pytest.raises(DataError, match=message):
            gltf_to_motion({**document, **change}, binary, "hostile.glb")


@needs_validator
@pytest.mark.parametrize("body", [True, False])
def test_khronos_validator_finds_nothing(dance, tmp_path, body):
    path = _write(dance[0], tmp_path / "v.glb", MARKERS, body)
    report = validate(path)
    assert (report["errors"], report["warnings"], report["infos"], report["hints"]) == (0, 0, 0, 0), report
    assert report["info"]["animationCount"] == 1 and report["info"]["hasSkins"] == body
    assert report["info"]["totalVertexCount"] == (0 if not body else 24 * 28)  # a box per bone, 28 bones


@needs_blender
def test_blender_imports_frames_and_floor_contact(dance, tmp_path):
    motion, path = dance
    data, _ = run_blender(path, tmp_path / "blender.json", fps=motion.fps)
    assert data["frames"] == motion.n_frames and data["fps"] == pytest.approx(motion.fps)
    heads = y_up(data["heads"])  # every joint and End Site: Blender makes a bone of each node of the skin
    ours = motion.positions(end_sites=True)
    assert heads.shape == ours.shape
    assert np.abs(heads[..., 1].min(axis=1) - ours[..., 1].min(axis=1)).max() < 0.01


@needs_three
def test_three_gltf_loader_plays_it_in_chromium(dance, tmp_path):
    from test_html_preview_browser import Chromium

    motion, path = dance
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "dance.glb").write_bytes(path.read_bytes())
    frames = [0, 17, 33, motion.n_frames - 1]
    browser = Chromium(tmp_path / "profile", resolve="MAP * ~NOTFOUND, EXCLUDE 127.0.0.1")  # our server only
    try:
        with served(tmp_path / "site") as url:
            browser.send("Page.navigate", browser.session, url=f"{url}/index.html")
            browser.js("new Promise(r => { const ok = () => window.ready ? r() : setTimeout(ok, 20); ok(); })")
            result = browser.js(f"loadDance('/dance.glb', {motion.fps}, {json.dumps(frames)})")
        assert not browser.errors()
    finally:
        browser.close()
    assert result["skinned"] and result["bones"] == 29 and result["tracks"] == 25
    assert result["duration"] == pytest.approx((motion.n_frames - 1) / motion.fps, abs=1e-4)
    lows = motion.positions(end_sites=True)[frames][..., 1].min(axis=1)
    assert np.abs(np.array(result["lows"]) - lows).max() < 0.01
    assert result["markers"]["beats"] == MARKERS.beats


def test_convert_bvh_to_glb_and_back_keeps_joint_positions(tmp_path, capsys):
    motion = _dance(dance24(), frames=40, seed=5)
    BvhFormat().write_motion(motion, tmp_path / "in.bvh")
    assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / "mid.glb"), "--markers"]) == 0
    assert main(["convert", str(tmp_path / "mid.glb"), "-o", str(tmp_path / "out.bvh")]) == 0
    back = BvhFormat().read_motion(tmp_path / "out.bvh")
    start = BvhFormat().read_motion(tmp_path / "in.bvh")
    assert np.abs(back.positions(end_sites=True) - start.positions(end_sites=True)).max() < 1e-3
    side = read_markers(tmp_path / "mid.markers.json")
    assert side.contacts == GlbFormat().read_motion(tmp_path / "mid.glb")[1].contacts
    assert "mid.glb + mid.markers.json (40 frames at 30 fps" in capsys.readouterr().out


def test_convert_resamples_and_changes_units(tmp_path):
    motion = _dance(dance24(), frames=60, seed=2)  # 2 s at 30 fps, metres
    BvhFormat().write_motion(motion, tmp_path / "in.bvh")
    assert main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / "out.bvh"), "--fps", "60",
                 "--units", "cm"]) == 0
    back = BvhFormat().read_motion(tmp_path / "out.bvh").conformed(motion.skeleton)
    assert back.fps == 60 and back.n_frames == 120
    pos = back.positions()
    assert np.abs(pos[::2] - 100 * motion.positions()).max() < 1e-2  # every other frame is a source frame
    mid = 0.5 * (motion.positions()[:-1] + motion.positions()[1:]) * 100
    assert np.abs(pos[1:-1:2] - mid).max() < 2.0  # in between: slerped, near the midpoint (cm)


def test_convert_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys):
    BvhFormat().write_motion(_dance(dance24(), frames=5), tmp_path / "in.bvh")
    (tmp_path / "rig.bvh").write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n"
                                      "}\nMOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0\n")
    for args, message in [
        (["--rig", str(tmp_path / "rig.bvh")], "rig.bvh"),
        (["--units", "km"], "invalid choice"),
        (["--fps", "0"], "--fps"),
        (["--music", str(tmp_path / "none.wav")], "none.wav"),
    ]:
        try:
            code = main(["convert", str(tmp_path / "in.bvh"), "-o", str(tmp_path / "out.glb"), *args])
        except SystemExit as exit_:  # argparse's own usage errors
            code = exit_.code
        assert code != 0
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err
        assert not (tmp_path / "out.glb").exists()


def test_glb_is_a_format_compose_and_convert_know():
    from dance_core.registry import get_registry

    entry = get_registry().find("motion-format", "glb")
    assert entry.suffixes == (".glb",) and entry.readable
    assert replace(MARKERS).to_dict()["sections"][1] == {"name": "chorus", "start": 1.2, "end": 2.0}
