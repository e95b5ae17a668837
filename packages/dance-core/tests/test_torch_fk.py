import numpy as np
import pytest
import torch

from dance_core.errors import DataError
from dance_core.motion.fk import forward_kinematics as numpy_fk
from dance_core.motion.representation import RotationRepresentation
from dance_core.motion.root import heading
from dance_core.motion.rotations import expmap_to_quat as numpy_expmap_to_quat
from dance_core.motion.rotations import quat_conj, quat_rotate, yaw_quat
from dance_core.motion.skeletons import dance24
from dance_core.motion.torch_fk import RotationKinematics, expmap_to_quat, forward_kinematics
from dance_core.synth.synthetic_dance import make_clip


@pytest.fixture(scope="module")
def dancer():
    return make_clip(0, seed=1, seconds=3.0, bpm=(90, 130), rate=8000, fps=30.0).motion.skeleton_motion


def test_forward_kinematics_equals_numpy():
    rng = np.random.default_rng(0)
    skeleton = dance24()
    quats = rng.normal(size=(5, 7, len(skeleton), 4))
    quats /= np.linalg.norm(quats, axis=-1, keepdims=True)
    root = rng.normal(size=(5, 7, 3))
    ref, _ = numpy_fk(skeleton, root, quats)
    got = forward_kinematics(skeleton, torch.tensor(root), torch.tensor(quats))
    assert got.shape == ref.shape
    np.testing.assert_allclose(got.numpy(), ref, atol=1e-12)


def test_expmap_to_quat_equals_numpy_and_has_gradients_at_zero():
    rng = np.random.default_rng(1)
    r = np.concatenate([rng.normal(size=(50, 3)) * 2, rng.normal(size=(5, 3)) * 1e-5, np.zeros((1, 3))])
    np.testing.assert_allclose(expmap_to_quat(torch.tensor(r)).numpy(), numpy_expmap_to_quat(r), atol=1e-12)
    x = torch.zeros(3, dtype=torch.float64, requires_grad=True)
    expmap_to_quat(x)[0].backward()
    assert torch.isfinite(x.grad).all() and x.grad[0] == pytest.approx(0.5)


@pytest.mark.parametrize("rotation", ["expmap", "quat"])
def test_kinematics_of_standardized_deltas_are_the_motion_in_its_own_frame(dancer, rotation):
    rep = RotationRepresentation(rotation, "deltas")
    values = rep.encode(dancer).astype(np.float64)
    mean, std = values.mean(0), values.std(0) + 0.1
    kin = RotationKinematics(dancer.skeleton, {"rotation": rotation, "root": "deltas"}, mean, std)
    got = kin(torch.tensor((values - mean) / std)[None])[0].numpy()
    world = dancer.positions()
    ground = dancer.root * np.array([1.0, 0.0, 1.0])
    turn = quat_conj(yaw_quat(heading(dancer.rotations[:, 0])))[:, None]
    ref = quat_rotate(turn, world - ground[:, None])  # heights unchanged, the rest relative to the root, facing +Z
    assert np.abs(got - ref).max() < 1e-4  # float32 statistics
    np.testing.assert_allclose(got[..., 1], world[..., 1], atol=1e-4)


def test_kinematics_reject_a_representation_they_cannot_read(dancer):
    with pytest.raises(DataError, match="6d"):
        RotationKinematics(dancer.skeleton, {"rotation": "6d", "root": "deltas"}, np.zeros(148), np.ones(148))
    with pytest.raises(DataError, match="channels"):
        RotationKinematics(dancer.skeleton, {"rotation": "expmap", "root": "deltas"}, np.zeros(10), np.ones(10))
