"""The ``mocap`` dataset: takes of any rig retargeted onto one skeleton, resampled, cached, music-less;
and a recipe that trains on them mixed with music-dance pairs."""

from pathlib import Path

import numpy as np
import pytest

from dance_core.contexts import DatasetContext
from dance_core.errors import DataError, PluginError
from dance_core.formats.bvh import BvhFormat
from dance_core.motion.retarget import retarget
from dance_core.motion.rig_maps import renamed
from dance_core.motion.skeletons import dance24
from dance_core.registry import get_registry

CMU = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"
pytestmark = pytest.mark.skipif(not CMU.exists(), reason="../shared/fixtures/bvh/cmu_01_01.bvh not available")


@pytest.fixture
def takes(tmp_path):
    """A folder of two short takes on two rigs: CMU's (120 fps) and a Mixamo-named one in cm (60 fps)."""
    folder = tmp_path / "takes"
    folder.mkdir()
    take = BvhFormat().read_motion(CMU).crop(0, 240)
    BvhFormat().write_motion(take, folder / "cmu_a.bvh")
    rig = renamed(dance24(), "mixamo", "mixamorig:").scaled(100.0, "cm")
    on_rig, _ = retarget(take.crop(0, 120), rig, ground=False)
    BvhFormat().write_motion(on_rig.resample(60.0), folder / "mixamo_b.bvh")
    (folder / "notes.txt").write_text("not a take\n")
    return folder


def mocap(folder, fps=20.0, **options):
    return get_registry().create("dataset", "mocap", {"path": str(folder), **options}, DatasetContext(fps=fps))


def test_takes_of_any_rig_become_clips_on_one_skeleton(takes, tmp_path):
    clips = mocap(takes, cache=str(tmp_path / "cache")).clips()
    assert [c.name for c in clips] == ["cmu_a", "mixamo_b"]
    for clip, seconds in zip(clips, (2.0, 1.0), strict=True):
        motion = clip.motion.skeleton_motion
        assert motion.skeleton.same_topology(dance24()) and motion.fps == 20.0
        assert abs(motion.duration - seconds) <= 1 / 20.0
        assert clip.audio is not None and not clip.audio.samples.any()  # silence: no music
        assert abs(clip.audio.samples.shape[0] / clip.audio.rate - motion.duration) < 1e-3
        low = motion.positions(end_sites=True)[..., 1].min(axis=1)
        assert low.min() > -0.02 and np.median(low) < 0.1  # on the floor
    # the two takes are the same movement: after retargeting both onto dance24 they agree (within what
    # grounding did to each one's legs and resampling 120 -> 60 -> 20 fps instead of 120 -> 20)
    a = clips[0].motion.skeleton_motion.positions()[:20]
    b = clips[1].motion.skeleton_motion.positions()[:20]
    rel = lambda p: p - p[:, :1]  # noqa: E731 - relative to the pelvis
    assert np.abs(rel(a) - rel(b)).max() < 0.015


def test_cache_is_used_and_keyed_by_what_shapes_the_result(takes, tmp_path, monkeypatch):
    from dance_core.data import mocap as module

    cache = tmp_path / "cache"
    first = mocap(takes, cache=str(cache)).clips()
    assert len(list(cache.glob("*.npz"))) == 2
    calls = []
    monkeypatch.setattr(module.MocapDataset, "retarget", lambda *a: calls.append(a) or None)
    again = mocap(takes, cache=str(cache)).clips()
    assert calls == []
    np.testing.assert_array_equal(again[0].motion.values, first[0].motion.values)
    monkeypatch.undo()
    other = mocap(takes, fps=30.0, cache=str(cache)).clips()  # another frame rate: new entries
    assert other[0].motion.fps == 30.0 and len(list(cache.glob("*.npz"))) == 4


def test_files_and_exclude_pick_takes_and_errors_are_clear(takes, tmp_path):
    assert [c.name for c in mocap(takes, files=["cmu_*"], cache=str(tmp_path / "c")).clips()] == ["cmu_a"]
    assert [c.name for c in mocap(takes, exclude=["cmu_*"], cache=str(tmp_path / "c")).clips()] == ["mixamo_b"]
    with pytest.raises(DataError, match="no motion files match"):
        mocap(takes, files=["salsa_*"], cache=str(tmp_path / "c")).clips()
    with pytest.raises(DataError, match="not a folder of motion files"):
        mocap(tmp_path / "nowhere", cache=str(tmp_path / "c")).clips()
    with pytest.raises(DataError, match="skeleton: no such motion file"):
        mocap(takes, skeleton="no-such-rig.bvh", cache=str(tmp_path / "c")).clips()
    with pytest.raises(PluginError, match="ground"):
        mocap(takes, ground="sometimes")


def test_a_recipe_trains_on_mocap_mixed_with_music_dance_pairs(takes, tmp_path):
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    recipe = tmp_path / "mocap.yaml"
    recipe.write_text(f"""extends: core-dance
data:
  dataset:
    plugin: mix
    datasets:
      - {{plugin: synthetic-dance, songs: 2, seconds: 6, sample_rate: 8000}}
      - {{plugin: mocap, path: {takes}, cache: {tmp_path / 'cache'}, sample_rate: 8000}}
  mirror: false
training: {{steps: 4, batch_size: 4, val_every: 4, checkpoint_every: 4}}
""")
    result = train(load_recipe(recipe), out=str(tmp_path / "run"), quiet=True)
    assert np.isfinite(result.last_loss) and result.checkpoint.exists()


def test_synthetic_dance_chains_real_moves_from_a_mocap_folder(takes, tmp_path, monkeypatch):
    """``synthetic-dance`` with ``mocap:`` dances the synthesized songs with the takes' real moves
    (no move labels), deterministically; ``dance synth --mocap`` writes the same kind of dataset."""
    from dance_core.cli.main import main

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    options = {"songs": 2, "seconds": 8, "sample_rate": 8000, "mocap": str(takes)}
    clips = get_registry().create("dataset", "synthetic-dance", options, DatasetContext(fps=30.0)).clips()
    assert [c.meta["dancer"] for c in clips] == ["real moves", "real moves"] and clips[0].texts == ()
    again = get_registry().create("dataset", "synthetic-dance", options, DatasetContext(fps=30.0)).clips()
    np.testing.assert_array_equal(clips[1].motion.values, again[1].motion.values)
    procedural = get_registry().create("dataset", "synthetic-dance", {**options, "mocap": None},
                                       DatasetContext(fps=30.0)).clips()
    np.testing.assert_array_equal(procedural[0].audio.samples, clips[0].audio.samples)  # same songs
    motion = clips[0].motion.skeleton_motion
    assert motion.skeleton.same_topology(dance24()) and motion.n_frames == 240
    assert np.ptp(motion.positions()[:, dance24().index("L_Wrist")], axis=0).max() > 0.1  # it dances
    out = tmp_path / "synth"
    assert main(["-q", "synth", "--out", str(out), "--songs", "1", "--seconds", "6", "--rate", "8000", "--fps", "30",
                 "--mocap", str(takes), "--mocap-exclude", "mixamo_*"]) == 0
    written = BvhFormat().read_motion(out / "synth-0000.bvh")
    assert written.n_frames == 180 and (out / "synth-0000.texts").read_text().strip() == ""
    assert main(["synth", "--out", str(out), "--mocap", str(tmp_path / "nowhere")]) == 1
