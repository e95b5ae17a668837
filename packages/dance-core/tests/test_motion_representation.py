import json

import numpy as np
import pytest

from dance_core.compose import compose
from dance_core.errors import CheckpointError, DataError
from dance_core.formats.bvh import BvhFormat
from dance_core.motion.representation import PositionRepresentation, RotationRepresentation
from dance_core.motion.root import root_to_deltas
from dance_core.motion.rotations import quat_conj, quat_rotate, yaw_quat
from dance_core.recipe import load_recipe
from dance_core.synth.synthetic_dance import make_clip
from dance_core.train import train

TINY = ["data.dataset.songs=3", "data.dataset.seconds=8", "training.steps=20", "training.batch_size=8",
        "training.val_every=20", "training.checkpoint_every=20", "training.log_every=10"]


@pytest.fixture(scope="module")
def dancer():
    return make_clip(0, seed=1, seconds=6.0, bpm=(90, 130), rate=8000, fps=30.0).motion.skeleton_motion


@pytest.mark.parametrize("rotation", ["expmap", "6d", "quat", "matrix"])
@pytest.mark.parametrize("root", ["deltas", "absolute"])
def test_rotation_representation_decodes_to_the_same_positions(dancer, rotation, root):
    rep = RotationRepresentation(rotation, root)
    values = rep.encode(dancer)
    assert values.dtype == np.float32 and values.shape == (dancer.n_frames, rep.dim(dancer.skeleton))
    back = rep.decode(values, dancer.skeleton, dancer.fps)
    ref = dancer.positions()
    if root == "deltas":  # decoding starts at the origin facing +Z: express the original in that frame
        _, _, start = root_to_deltas(dancer.root, dancer.rotations[:, 0])
        ref = quat_rotate(quat_conj(yaw_quat(start.yaw)), ref - np.array([start.x, 0.0, start.z]))
    assert np.abs(back.positions() - ref).max() < 1e-4  # float32 features


def test_transflower_layout_is_67_dims_on_21_joints():
    from dance_core.motion.skeletons import transflower21

    rep = RotationRepresentation("expmap", "deltas")
    assert rep.dim(transflower21()) == 67
    assert rep.channels(transflower21())[:4] == ["root.dx", "root.dz", "root.y", "root.dyaw"]


def test_joint_subset_keeps_the_rest_at_identity(dancer):
    rep = RotationRepresentation("6d", "absolute", ["Pelvis", "L_Hip", "L_Knee"])
    back = rep.decode(rep.encode(dancer), dancer.skeleton, dancer.fps)
    assert rep.dim(dancer.skeleton) == 3 + 18
    np.testing.assert_allclose(back.rotations[:, 5], np.array([0, 0, 0, 1.0]).repeat(1)[None].repeat(len(back.root), 0))
    with pytest.raises(DataError, match="root"):
        RotationRepresentation(joints=["L_Hip"]).channels(dancer.skeleton)


@pytest.mark.parametrize("root", ["deltas", "absolute"])
def test_position_representation_round_trip(dancer, root):
    rep = PositionRepresentation(3, root)
    back = rep.decode(rep.encode(dancer), dancer.skeleton, dancer.fps)
    shift = dancer.root[:1] * np.array([1, 0, 1]) if root == "deltas" else 0
    np.testing.assert_allclose(back.positions() + shift, dancer.positions(), atol=1e-4)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    recipe = load_recipe("core-dance", TINY)
    out = tmp_path_factory.mktemp("dance-run")
    return recipe, train(recipe, out=str(out), quiet=True)


def test_checkpoint_stores_the_representation_and_skeleton(run):
    from dance_core.checkpoint import load_checkpoint

    recipe, result = run
    info = load_checkpoint(result.checkpoint).motion
    assert info.representation == "rotations"
    assert info.options == {"rotation": "expmap", "root": "deltas", "joints": None}
    assert info.skeleton.name == "dance24" and info.dim == 4 + 24 * 3
    assert info.channels[:2] == ("root.dx", "root.dz")
    stored = info.to_dict()
    assert stored["representation"] == {"plugin": "rotations", "rotation": "expmap", "root": "deltas", "joints": None}
    assert type(info).from_dict(json.loads(json.dumps(stored))).to_dict() == stored


def test_compose_writes_bvh_that_decodes_the_generated_features(run, tmp_path):
    recipe, result = run
    clip = make_clip(0, seed=5, seconds=4.0, bpm=(100, 100), rate=16000, fps=20.0)
    from dance_core.formats.wav import write_wav

    write_wav(tmp_path / "song.wav", clip.audio.samples, clip.audio.rate)
    recipe = load_recipe("core-dance", [*TINY, "compose.formats=[bvh, npz, html]"])
    paths = compose(recipe, music=[str(tmp_path / "song.wav")], checkpoint=str(result.checkpoint),
                    out_dir=str(tmp_path / "out"), quiet=True)
    assert sorted(p.suffix for p in paths) == [".bvh", ".html", ".npz"]
    assert "data:audio/wav;base64," in (tmp_path / "out" / "song.html").read_text()  # the song plays along
    motion = BvhFormat().read_motion(tmp_path / "out" / "song.bvh")
    assert motion.skeleton.names[:3] == ["Pelvis", "L_Hip", "L_Knee"]  # BVH lists joints depth-first
    motion = motion.conformed(clip.motion.skeleton_motion.skeleton)
    assert motion.n_frames == 80 and motion.fps == 20.0 and len(motion.skeleton) == 24
    with np.load(tmp_path / "out" / "song.npz") as f:
        features = f["values"]
    rep = RotationRepresentation("expmap", "deltas")
    decoded = rep.decode(features, motion.skeleton, 20.0)
    np.testing.assert_allclose(motion.positions(), decoded.positions(), atol=1e-4)
    # a BVH seed motion is encoded with the checkpoint's representation
    BvhFormat().write_motion(clip.motion.skeleton_motion.resample(60.0), tmp_path / "seed.bvh")
    again = compose(load_recipe("core-dance", [*TINY, f"compose.seed_motion={tmp_path / 'seed.bvh'}"]),
                    music=[str(tmp_path / "song.wav")], checkpoint=str(result.checkpoint),
                    out_dir=str(tmp_path / "seeded"), quiet=True)
    assert BvhFormat().read_motion(again[0]).n_frames == 80


def test_checkpoint_refuses_a_recipe_with_another_representation(run, tmp_path):
    _, result = run
    other = load_recipe("core-dance", [*TINY, "motion.rotation=6d"])
    with pytest.raises(CheckpointError, match="motion.rotation"):
        compose(other, music=["x.wav"], checkpoint=str(result.checkpoint), out_dir=str(tmp_path), quiet=True)


def test_skeletal_dataset_without_a_representation_is_a_recipe_error(tmp_path):
    from dance_core.errors import RecipeError

    recipe = load_recipe("core-dance", [*TINY, "motion=null"])
    with pytest.raises(RecipeError, match="motion: dataset 'synthetic-dance' yields skeletal motion"):
        train(recipe, out=str(tmp_path), quiet=True)


def test_training_learns_and_mirroring_doubles_the_clips(run):
    from dance_core.data.prepare import dataset_sources

    recipe, result = run
    assert result.last_loss < 0.8 * result.first_loss
    sources = dataset_sources(load_recipe("core-dance", [*TINY, "data.dataset.songs=2", "data.dataset.seconds=4"]))
    assert [s.name for s in sources] == ["synth-0000", "synth-0000-mirrored", "synth-0001", "synth-0001-mirrored"]
    a, b = sources[0].motion.skeleton_motion, sources[1].motion.skeleton_motion
    pairs = a.skeleton.mirror_pairs()
    np.testing.assert_allclose(b.root, a.root * [-1, 1, 1])
    assert np.abs(np.abs((b.rotations[:, pairs] * a.rotations * [1, -1, -1, 1]).sum(-1)) - 1).max() < 1e-9
    np.testing.assert_allclose(sources[1].motion.values[:, 2], sources[0].motion.values[:, 2])  # same height


def test_2d_keypoints_round_trip_through_the_position_representation():
    from dance_core.motion.motion import Motion
    from dance_core.motion.skeletons import body25

    skel = body25()
    rng = np.random.default_rng(4)
    pos = skel.rest_positions()[None] + rng.normal(0, 0.05, (15, 25, 3))
    pos[..., 2] = 0.0
    motion = Motion(skel, 30.0, pos[:, 0], joint_positions=pos)
    rep = PositionRepresentation(2, "absolute")
    values = rep.encode(motion)
    assert values.shape == (15, 3 + 50)
    np.testing.assert_allclose(rep.decode(values, skel, 30.0).positions(), pos, atol=1e-5)
