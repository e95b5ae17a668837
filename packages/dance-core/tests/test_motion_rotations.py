import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dance_core.motion import rotations as R
from dance_core.motion.fk import MATRIX_FRAMES, end_site_positions, forward_kinematics, joint_positions
from dance_core.motion.skeletons import dance24

ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]


@pytest.fixture
def quats():
    return Rotation.random(200, random_state=3).as_quat().reshape(50, 4, 4)


def same_rotation(a, b, tol=1e-9):
    return np.abs(np.abs((a * b).sum(-1)) - 1).max() < tol


@pytest.mark.parametrize("kind", ["quat", "expmap", "6d", "matrix"])
def test_every_representation_round_trips(quats, kind):
    x = R.to_kind(quats, kind)
    assert x.shape == (50, 4, R.KINDS[kind])
    assert same_rotation(R.from_kind(x, kind), quats)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_in_every_bvh_order_matches_the_matrix_product(order):
    angles = np.array([[30.0, -50.0, 80.0]])
    axis = {c: Rotation.from_euler(c.lower(), a, degrees=True).as_matrix()
            for c, a in zip(order, angles[0], strict=True)}
    expected = axis[order[0]] @ axis[order[1]] @ axis[order[2]]  # BVH: first channel outermost
    q = R.euler_to_quat(angles, order)
    np.testing.assert_allclose(R.quat_to_matrix(q)[0], expected, atol=1e-12)
    np.testing.assert_allclose(R.quat_to_euler(q, order, continuous=False), angles, atol=1e-9)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_curves_stay_continuous_through_wraps_and_flips(order):
    t = np.linspace(0, 1, 400)
    q = Rotation.from_euler(order, np.stack([720 * t, 100 * np.sin(6 * t), -500 * t], -1), degrees=True).as_quat()
    e = R.quat_to_euler(q[:, None], order)[:, 0]
    assert np.abs(np.diff(e, axis=0)).max() < 15  # no 180 or 360 degree jumps
    assert same_rotation(R.euler_to_quat(e, order), q)


def test_expmap_is_unrolled_across_pi():
    angle = np.linspace(0.5, 3 * np.pi, 300)  # keeps turning about one axis past pi
    q = R.expmap_to_quat(angle[:, None] * np.array([0.0, 0.6, 0.8]))
    naive = R.quat_to_expmap(q)
    assert np.abs(np.diff(naive, axis=0)).max() > 1.0  # scipy's principal value jumps at pi
    r = R.to_kind(q[:, None], "expmap")[:, 0]
    assert np.abs(np.diff(r, axis=0)).max() < 0.05
    np.testing.assert_allclose(np.linalg.norm(r, axis=-1), angle, atol=1e-9)


def test_quaternion_signs_are_made_continuous(quats):
    seq = R.expmap_to_quat(np.linspace(0, 6, 100)[:, None] * np.array([1.0, 0, 0]))
    seq[::2] *= -1
    fixed = R.unroll_quat(seq)
    assert ((fixed[1:] * fixed[:-1]).sum(-1) > 0).all()


def test_forward_kinematics_batches():
    skel = dance24()
    rng = np.random.default_rng(0)
    q = Rotation.random(2 * 5 * 24, random_state=1).as_quat().reshape(2, 5, 24, 4)
    root = rng.normal(size=(2, 5, 3))
    pos, _ = forward_kinematics(skel, root, q)
    assert pos.shape == (2, 5, 24, 3)
    one, _ = forward_kinematics(skel, root[1, 3], q[1, 3])
    np.testing.assert_allclose(pos[1, 3], one)
    # bone lengths are preserved by any rotation
    bones = np.linalg.norm(pos[..., 1:, :] - pos[..., skel.parents[1:], :], axis=-1)
    np.testing.assert_allclose(bones, np.broadcast_to(np.linalg.norm(skel.offsets[1:], axis=-1), bones.shape))


@pytest.mark.parametrize("shape", [(1,), (3, 4), (MATRIX_FRAMES + 1,)])
def test_joint_positions_are_forward_kinematics_positions_with_the_end_sites(shape):
    """Few frames go through rotation matrices, many through quaternions: the same positions either way."""
    skel = dance24()
    n = int(np.prod(shape))
    q = Rotation.random(n * 24, random_state=4).as_quat().reshape(*shape, 24, 4)
    root = np.random.default_rng(1).normal(size=(*shape, 3))
    pos, world = forward_kinematics(skel, root, q)
    np.testing.assert_allclose(joint_positions(skel, root, q), pos, atol=1e-12)
    ends = joint_positions(skel, root, q, end_sites=True)
    assert ends.shape == (*shape, 24 + len(skel.end_sites), 3)
    np.testing.assert_allclose(ends, np.concatenate([pos, end_site_positions(skel, pos, world)], axis=-2), atol=1e-12)


def test_identity_rotations_give_the_rest_pose():
    skel = dance24()
    q = np.zeros((1, 24, 4))
    q[..., 3] = 1
    pos, _ = forward_kinematics(skel, skel.offsets[:1], q)
    np.testing.assert_allclose(pos[0], skel.rest_positions(), atol=1e-12)
