"""``dance compose`` delivering to animators: onto a rig (``--rig``), at a frame rate (``--fps``), in units
(``--units``), with the song's markers (``--markers``), and the same as recipe fields; bad rigs are one line
before any work. A tiny core-dance model (dance24, rotations) makes the dances."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.formats.bvh import BvhFormat
from dance_core.formats.glb import GlbFormat
from dance_core.motion.markers import read_markers
from dance_core.motion.rig_maps import arms_lowered, renamed
from dance_core.motion.skeletons import dance24

sys.path.insert(0, str(Path(__file__).parent))
from compose_helpers import TINY, click_song, tiny_checkpoint  # noqa: E402
from test_bvh_dcc import _dance  # noqa: E402


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A tiny core-dance checkpoint and a 6 s click-track song at 120 bpm."""
    root = tmp_path_factory.mktemp("delivery")
    checkpoint = tiny_checkpoint(root)
    return checkpoint, click_song(root / "song.wav", 6.0)


@pytest.fixture
def hero(tmp_path):
    """A Mixamo-named A-pose rig in centimetres."""
    rig = renamed(arms_lowered(dance24().scaled(100.0, "cm")), "mixamo", prefix="mixamorig:")
    BvhFormat().write_motion(_dance(rig, frames=1), tmp_path / "hero.bvh")
    return tmp_path / "hero.bvh"


def compose_cli(model, out, *extra):
    checkpoint, song = model
    return main(["compose", "core-dance", *(f"--set={s}" for s in TINY), "--checkpoint", checkpoint,
                 "--music", song, "-o", str(out), "--quiet", *extra])


def test_rig_fps_units_and_markers_on_compose(model, hero, tmp_path):
    assert compose_cli(model, tmp_path / "out", "--format", "bvh", "--format", "glb", "--rig", str(hero),
                       "--fps", "30", "--units", "cm", "--markers") == 0
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "song.bvh", "song.glb", "song.markers.json"]
    motion = BvhFormat().read_motion(out / "song.bvh")
    assert "mixamorig:LeftUpLeg" in motion.skeleton.names and "L_Hip" not in motion.skeleton.names
    assert motion.fps == 30.0 and motion.n_frames == 180  # 6 s at 20 fps resampled to 30
    assert 120 < motion.skeleton.height() < 220  # centimetres
    assert abs(motion.positions(end_sites=True)[..., 1].min()) < 2.0  # the retargeted feet on the floor (cm)
    markers = read_markers(out / "song.markers.json")
    assert json.loads((out / "song.markers.json").read_text())["fps"] == 30.0
    beats = np.array(markers.beats)
    assert len(beats) >= 8 and np.abs(np.diff(beats) - 0.5).max() < 0.06  # the click track's 120 bpm
    assert markers.contacts  # the dance's own foot contacts
    glb, carried = GlbFormat().read_motion(out / "song.glb")
    assert glb.n_frames == 180 and carried.beats == pytest.approx(markers.beats)


def test_recipe_fields_say_the_same(model, hero, tmp_path):
    recipe = tmp_path / "r.yaml"
    recipe.write_text(f"extends: core-dance\ncompose:\n  rig: {hero.name}\n  output_fps: 40\n  units: cm\n"
                      "  markers: true\n  formats: [bvh]\n")
    checkpoint, song = model
    assert main(["compose", str(recipe), *(f"--set={s}" for s in TINY), "--checkpoint", checkpoint, "--music",
                 song, "-o", str(tmp_path / "out"), "--quiet"]) == 0
    motion = BvhFormat().read_motion(tmp_path / "out" / "song.bvh")
    assert motion.fps == 40.0 and motion.n_frames == 240 and "mixamorig:Hips" in motion.skeleton.names
    assert (tmp_path / "out" / "song.markers.json").is_file()


def test_a_rig_that_cannot_be_mapped_is_one_line_before_any_work(model, tmp_path, capsys):
    from dance_core.motion.skeleton import Skeleton

    odd = Skeleton(["a", "b", "c"], [-1, 0, 1], np.array([[0, 1, 0], [0, 0.5, 0], [0, 0.5, 0]], float), name="odd")
    BvhFormat().write_motion(_dance(odd, frames=1), tmp_path / "odd.bvh")
    cases = {"--rig=" + str(tmp_path / "odd.bvh"): "odd.bvh",
             "--rig=" + str(tmp_path / "missing.bvh"): "--rig",
             "--rig-map=nothing.yaml": "--rig-map"}
    for option, named in cases.items():
        assert compose_cli(model, tmp_path / "out", option) != 0
        err = capsys.readouterr().err.strip()
        assert named in err and len(err.splitlines()) == 1, err
        assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_convert_and_compose_share_the_delivery(model, hero, tmp_path):
    """The same dance delivered by compose --rig and by convert --rig on compose's plain output."""
    assert compose_cli(model, tmp_path / "plain", "--format", "bvh") == 0
    assert compose_cli(model, tmp_path / "rigged", "--format", "bvh", "--rig", str(hero)) == 0
    assert main(["convert", str(tmp_path / "plain" / "song.bvh"), "-o", str(tmp_path / "conv.bvh"),
                 "--rig", str(hero)]) == 0
    a = BvhFormat().read_motion(tmp_path / "rigged" / "song.bvh").positions()
    b = BvhFormat().read_motion(tmp_path / "conv.bvh").positions()
    assert np.abs(a - b).max() < 0.05  # BVH text of the plain dance in between (cm)


def test_up_z_writes_bvh_z_up_and_glb_y_up(model, tmp_path, capsys):
    """``--up z`` (and ``compose.up: z``): the BVH file Z up, the glb beside it Y up, one dance in both;
    a run whose only output is a glb is refused in one line before any work."""
    assert compose_cli(model, tmp_path / "out", "--format", "bvh", "--format", "glb", "--up", "z") == 0
    bvh = BvhFormat().read_motion(tmp_path / "out" / "song.bvh")
    raw = bvh.positions()
    glb, _ = GlbFormat().read_motion(tmp_path / "out" / "song.glb")
    y = glb.positions()[:, [glb.skeleton.names.index(name) for name in bvh.skeleton.names]]
    np.testing.assert_allclose(raw, np.stack([y[..., 0], -y[..., 2], y[..., 1]], axis=-1), atol=1e-4)
    np.testing.assert_allclose(BvhFormat(up="z").read_motion(tmp_path / "out" / "song.bvh").positions(), y,
                               atol=1e-4)
    recipe = tmp_path / "r.yaml"
    recipe.write_text("extends: core-dance\ncompose:\n  up: z\n  formats: [bvh]\n")
    checkpoint, song = model
    assert main(["compose", str(recipe), *(f"--set={s}" for s in TINY), "--checkpoint", checkpoint, "--music",
                 song, "-o", str(tmp_path / "recipe"), "--quiet"]) == 0
    assert (tmp_path / "recipe" / "song.bvh").read_bytes() == (tmp_path / "out" / "song.bvh").read_bytes()
    assert compose_cli(model, tmp_path / "glb", "--format", "glb", "--up", "z") != 0
    err = capsys.readouterr().err.strip()
    assert "--up z" in err and "glTF" in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "glb").exists() or not any((tmp_path / "glb").iterdir())
