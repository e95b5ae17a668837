"""Grounding on crafted SMPL-24 motion: floating, sinking, jumps, skating, and motion already right; a real
take grounded twice."""

from pathlib import Path

import numpy as np
import pytest

from dance_core.motion.grounding import GroundingOptions, find_feet, ground, sole_heights
from dance_core.motion.ik import two_bone_ik
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat, quat_rotate
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import dance24, transflower21

REST = dance24().rest_positions()


FPS = 20.0
SOLE = GroundingOptions().sole
#: root height standing at rest: dance24's rest pose has its toe tips (End Sites) on the floor, which
#: grounding takes as the soles
STAND = float(REST[0, 1])
L_SHOULDER, R_SHOULDER, L_ELBOW, SPINE3, NECK = 16, 17, 18, 9, 12
LEGS = {1, 2, 4, 5, 7, 8, 10, 11}  # hips, knees, ankles, toes
UPPER = [j for j in range(24) if j not in LEGS and j != 0]


def dancer(seconds=4.0, lift=0.0):
    """A standing dance24 dancer waving its arms and nodding (feet still), root ``lift`` above standing."""
    n = int(seconds * FPS)
    t = np.arange(n) / FPS
    rot = np.zeros((n, 24, 3))
    rot[:, L_SHOULDER, 2] = -1.2 + 0.5 * np.sin(2 * np.pi * t)
    rot[:, R_SHOULDER, 2] = 1.2 + 0.5 * np.sin(2 * np.pi * t + 1)
    rot[:, L_ELBOW, 1] = -0.4 + 0.3 * np.sin(4 * np.pi * t)
    rot[:, SPINE3, 1] = 0.2 * np.sin(np.pi * t)
    rot[:, NECK, 0] = 0.15 * np.sin(4 * np.pi * t)
    root = np.zeros((n, 3))
    root[:, 1] = STAND + lift
    return Motion(dance24(), FPS, root, expmap_to_quat(rot))


def soles(motion):
    """Per frame, the lower sole's height above the floor."""
    return sole_heights(motion, motion.positions(end_sites=True), find_feet(motion.skeleton), SOLE).min(1)


def horizontal_speed(motion, joint):
    xz = motion.positions()[:, joint][:, [0, 2]]
    return np.linalg.norm(np.diff(xz, axis=0), axis=-1) * motion.fps


def test_feet_are_found_by_name_and_a_skeleton_without_feet_is_skipped():
    assert find_feet(dance24()) == (7, 10, 8, 11)
    tf = transflower21()
    assert [tf.names[j] for j in find_feet(tf)] == ["LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"]
    stick = Skeleton(["root", "a", "b"], [-1, 0, 1], np.array([[0, 1.0, 0], [0, -0.5, 0], [0, -0.5, 0]]))
    m = Motion(stick, FPS, np.ones((10, 3)), np.tile([0.0, 0, 0, 1], (10, 3, 1)))
    out, report = ground(m)
    assert out is m and report.skipped and "feet" in report.note
    assert report.summary().startswith("grounding skipped")


def test_a_floating_dancer_is_put_back_on_the_floor():
    m = dancer(lift=0.30)
    assert soles(m).min() > 0.29
    out, report = ground(m)
    assert report.contacts == (1, 1) and report.contact_fraction == 1.0
    np.testing.assert_allclose(soles(out), 0.0, atol=1e-3)
    assert report.mean_correction == pytest.approx(-0.30, abs=1e-3)


def test_a_sunk_dancer_is_raised():
    m = dancer(lift=-0.12)
    out, report = ground(m)
    assert sum(report.contacts) >= 2
    np.testing.assert_allclose(soles(out), 0.0, atol=1e-3)
    assert report.mean_correction == pytest.approx(0.12, abs=1e-3)


@pytest.mark.parametrize("lift", [0.0, 0.3])
def test_a_jump_stays_in_the_air(lift):
    m = dancer(lift=lift)
    t = np.arange(m.n_frames) / FPS
    flight = (t >= 1.8) & (t < 2.2)  # 0.4 s in the air, 20 cm up at the top
    m.root[flight, 1] += 0.2 * np.sin(np.pi * (t[flight] - 1.8) / 0.4)
    out, report = ground(m)
    h = soles(out)
    assert h[~flight].max() < 0.01 and h.min() > -1e-6  # on the floor before and after, never below
    top = np.argmax(m.root[:, 1])
    assert h[top] > 0.17  # still jumps (nearly) as high
    assert report.mean_correction == pytest.approx(-lift, abs=0.01)


def test_a_skating_foot_is_pinned_and_nothing_but_the_legs_moves():
    m = dancer(seconds=3.0)
    t = np.arange(m.n_frames) / FPS
    # the body slides 10 cm sideways in a second while the feet should stay planted
    m.root[:, 0] += 0.10 * np.clip(t - 1.0, 0, 1) ** 2 * (3 - 2 * np.clip(t - 1.0, 0, 1))
    ankle = 7
    assert horizontal_speed(m, ankle).max() > 0.1
    out, report = ground(m)
    assert report.contacts == (1, 1)
    assert horizontal_speed(out, ankle).max() < 0.01  # was 15 cm/s
    assert report.skating_after < 0.1 * report.skating_before
    # the root's horizontal track and the upper body around the root are as they were
    np.testing.assert_array_equal(out.root[:, [0, 2]], m.root[:, [0, 2]])
    before, after = m.positions(), out.positions()
    np.testing.assert_allclose(after[:, UPPER] - out.root[:, None], before[:, UPPER] - m.root[:, None], atol=1e-9)
    np.testing.assert_array_equal(out.rotations[:, UPPER + [0]], m.rotations[:, UPPER + [0]])
    # the legs still have their bone lengths (IK only rotates)
    bones = [(1, 4), (4, 7), (7, 10)]
    for a, b in bones:
        np.testing.assert_allclose(np.linalg.norm(after[:, a] - after[:, b], axis=-1),
                                   np.linalg.norm(before[:, a] - before[:, b], axis=-1), atol=1e-9)


def test_a_grounded_dance_is_left_alone():
    m = dancer()
    out, report = ground(m)
    assert report.contacts == (1, 1)
    assert np.abs(out.positions() - m.positions()).max() < 1e-3
    assert abs(report.mean_correction) < 1e-6


def test_units_other_than_metres():
    skel = transflower21()  # centimetres
    n = 60
    root = np.zeros((n, 3))
    root[:, 1] = 150.0  # floating: the rest soles are near 95 cm
    m = Motion(skel, FPS, root, np.tile([0.0, 0, 0, 1], (n, len(skel), 1)))
    out, report = ground(m)
    feet = find_feet(skel)
    h = sole_heights(out, out.positions(end_sites=True), feet, 100 * SOLE).min(1)
    np.testing.assert_allclose(h, 0.0, atol=0.1)
    rest = skel.rest_positions()
    toe_below_root = rest[0, 1] - rest[feet[1], 1]  # 94 cm: the toe's End Site points forward, at its height
    assert report.mean_correction == pytest.approx(-(150.0 - toe_below_root) / 100, abs=1e-4)


def test_the_soles_are_the_rest_poses_lowest_points_and_pointed_toes_count():
    """With End Sites the sole is where the rest foot touches the floor (no assumed toe height), the
    toe tips count (a pointed foot is not pushed through the floor), and a rig without toe joints
    (CMU's Daz-friendly conversion: an End Site under the ankle) is grounded through its End Sites."""
    skel = dance24()
    rest = np.tile([0.0, 0, 0, 1], (1, len(skel), 1))
    m = Motion(skel, FPS, skel.offsets[:1], rest)
    np.testing.assert_allclose(sole_heights(m, m.positions(end_sites=True), find_feet(skel), SOLE), 0.0, atol=1e-9)
    pointed = rest.copy()
    pointed[0, skel.index("L_Ankle")] = expmap_to_quat(np.array([1.0, 0.0, 0.0]))  # toes 57 degrees down
    m = Motion(skel, FPS, skel.offsets[:1], pointed)
    tips = m.positions(end_sites=True)[0, len(skel):, 1]
    assert sole_heights(m, m.positions(end_sites=True), find_feet(skel), SOLE)[0, 0] == pytest.approx(tips.min())
    from dance_core.motion.rig_maps import PRESETS

    daz_names = {c: n[0].format() for c, n in PRESETS["cmu-daz"].items()}
    keep = [j for j, n in enumerate(skel.names) if n in daz_names]
    def kept_parent(j):
        p = skel.parents[j]
        while p >= 0 and p not in keep:
            p = skel.parents[p]
        return p

    parents = [keep.index(kept_parent(j)) if j else -1 for j in keep]
    rest_pos = skel.rest_positions()
    offsets = np.array([rest_pos[j] - (rest_pos[kept_parent(j)] if j else 0) for j in keep])
    ends = {keep.index(skel.index(f"{s}_Ankle")): rest_pos[skel.index(f"{s}_Foot")] - rest_pos[skel.index(f"{s}_Ankle")]
            + [0, -0.0204, 0.06] for s in "LR"}
    daz = Skeleton([daz_names[skel.names[j]] for j in keep], parents, offsets, end_sites=ends, name="daz")
    feet = find_feet(daz)
    assert feet == (daz.index("lFoot"), daz.index("lFoot"), daz.index("rFoot"), daz.index("rFoot"))
    n = 40
    root = np.tile(offsets[:1] + [0.0, 0.25, 0.0], (n, 1))  # 25 cm up
    out, report = ground(Motion(daz, FPS, root, np.tile([0.0, 0, 0, 1], (n, len(daz), 1))))
    assert not report.skipped and report.mean_correction == pytest.approx(-0.25, abs=1e-3)


def test_two_bone_ik_reaches_and_bends_a_straight_limb_forwards():
    hip, knee, ankle = np.array([[0.0, 1, 0]]), np.array([[0.0, 0.5, 0]]), np.array([[0.0, 0, 0]])
    target = np.array([[0.0, 0.2, 0.1]])
    q_hip, q_knee = two_bone_ik(hip, knee, ankle, target, np.array([[0.0, 0, 1]]))
    new_knee = hip + quat_rotate(q_hip, knee - hip)
    new_ankle = new_knee + quat_rotate(q_hip, quat_rotate(q_knee, ankle - knee))
    np.testing.assert_allclose(new_ankle, target, atol=1e-9)
    assert new_knee[0, 2] > 0.1  # the knee goes forwards


@pytest.fixture(scope="module")
def floating_checkpoint(tmp_path_factory):
    """A tiny core-dance model trained on dancers that float 30 cm above the floor."""
    from dance_core.data.synthetic_beats import click_track
    from dance_core.formats.bvh import BvhFormat
    from dance_core.formats.wav import write_wav
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    data = tmp_path_factory.mktemp("floating")
    for k in range(4):
        m = dancer(seconds=6.0, lift=0.30)
        m.root[:, 0] += 0.1 * k
        BvhFormat().write_motion(m, data / f"song{k}.bvh")
        beats = np.arange(0.0, 6.0, 0.5 + 0.05 * k)
        write_wav(data / f"song{k}.wav", click_track(beats, 6.0, 16000, np.random.default_rng(k)), 16000)
    tiny = [f"data.dataset={{plugin: folder, path: {data}}}", "data.val_fraction=0.25", "data.mirror=false",
            "training.steps=30", "training.batch_size=16", "training.val_every=30", "training.checkpoint_every=30"]
    recipe = load_recipe("core-dance", tiny)
    return recipe, train(recipe, out=str(tmp_path_factory.mktemp("run")), quiet=True).checkpoint, data


@pytest.mark.parametrize("on", [True, False])
def test_compose_grounds_skeletal_dances(floating_checkpoint, tmp_path, on):
    from dance_core.compose import compose
    from dance_core.data.files import read_motion_file as read_motion
    from dance_core.recipe import load_recipe
    from dance_core.registry import get_registry

    recipe, checkpoint, data = floating_checkpoint
    recipe = load_recipe("core-dance", [f"data.dataset={{plugin: folder, path: {data}}}", "data.mirror=false",
                                        "compose.formats=[bvh, npz]", f"compose.ground={str(on).lower()}"])
    assert recipe.compose.ground is on
    paths = compose(recipe, music=[str(data / "song0.wav")], checkpoint=str(checkpoint),
                    out_dir=str(tmp_path), quiet=True)
    bvh = next(p for p in paths if p.suffix == ".bvh")
    motion = read_motion(bvh, get_registry()).skeleton_motion
    lowest = soles(motion)
    if on:
        assert lowest.min() > -2e-3 and np.median(lowest) < 5e-3  # on the floor, not below it
    else:
        assert np.median(lowest) > 0.2  # the model floats like its training data


def test_restless_feet_without_contacts_still_come_down_to_the_floor():
    """Jittery generated motion: legs kick fast all the time (no contact), the body drifts upwards."""
    m = dancer(seconds=8.0)
    n = m.n_frames
    t = np.arange(n) / FPS
    rot = np.zeros((n, 24, 3))
    rot[:, 1, 0] = -0.5 * np.clip(np.sin(9 * t), 0, None)  # left hip kicks forward, fast
    rot[:, 2, 0] = -0.5 * np.clip(-np.sin(9 * t), 0, None)  # right hip, alternating
    root = m.root.copy()
    root[:, 1] += 0.25 * t / 8.0  # rises 25 cm over the song
    kicking = Motion(m.skeleton, FPS, root, expmap_to_quat(rot))
    out, report = ground(kicking)
    lows = soles(out)
    window = int(FPS)  # every second, some foot comes down to the floor
    per_second = lows[: n // window * window].reshape(-1, window).min(1)
    np.testing.assert_array_less(np.abs(per_second), 0.02)
    assert lows.min() > -1e-3


def causal(motion):
    """The motion grounded frame by frame by ``CausalGrounding``."""
    from dance_core.motion.causal_grounding import CausalGrounding

    g = CausalGrounding(motion.skeleton, motion.fps)
    frames = [g(motion.root[i], motion.rotations[i]) for i in range(motion.n_frames)]
    return Motion(motion.skeleton, motion.fps, np.stack([f[0] for f in frames]), np.stack([f[1] for f in frames]))


@pytest.mark.parametrize("lift", [0.30, -0.12])
def test_causal_grounding_brings_a_floating_or_sunk_dancer_to_the_floor(lift):
    out = causal(dancer(lift=lift))
    h = soles(out)
    assert h.min() > -1e-6  # never below the floor, from the first frame
    assert np.abs(h[5:]).max() < 0.01  # on it once the one-pole filter has settled (0.1 s)
    np.testing.assert_allclose(out.root[:, [0, 2]], dancer(lift=lift).root[:, [0, 2]])


def test_causal_grounding_keeps_a_jump_and_pins_a_skating_foot():
    m = dancer()
    t = np.arange(m.n_frames) / FPS
    flight = (t >= 1.8) & (t < 2.2)
    m.root[flight, 1] += 0.2 * np.sin(np.pi * (t[flight] - 1.8) / 0.4)
    h = soles(causal(m))
    assert h[np.argmax(m.root[:, 1])] > 0.17 and h[~flight].max() < 0.01
    m = dancer(seconds=3.0)
    m.root[:, 0] += 0.10 * np.clip(t[: m.n_frames] - 1.0, 0, 1) ** 2 * (3 - 2 * np.clip(t[: m.n_frames] - 1.0, 0, 1))
    out = causal(m)
    assert horizontal_speed(m, 7).max() > 0.1 and horizontal_speed(out, 7).max() < 0.01  # pinned where it landed
    np.testing.assert_array_equal(out.rotations[:, UPPER + [0]], m.rotations[:, UPPER + [0]])


CMU = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"


@pytest.mark.skipif(not CMU.exists(), reason="../shared/fixtures/bvh/cmu_01_01.bvh not available")
def test_grounding_a_grounded_take_changes_it_by_little():
    """Idempotence on a real take (23 s at 120 fps, its floor 4 cm off and its feet skating): a second pass
    finds the contacts again and moves no joint by more than about a centimetre (1 % of the leg); it moved
    the legs by 14 cm before the contacts were settled and the fades shifted instead of pulled."""
    from dance_core.formats.bvh import BvhFormat
    from dance_core.motion.grounding import metres_per_unit

    take = BvhFormat().read_motion(CMU)
    once, first = ground(take)
    twice, second = ground(once)
    assert first.skating_after < 0.1 * first.skating_before and abs(first.mean_correction) > 0.03  # it grounds
    feet = find_feet(take.skeleton)
    unit = metres_per_unit(take.skeleton, feet, GroundingOptions())
    knee = take.skeleton.parents[feet[0]]
    leg = (np.linalg.norm(take.skeleton.offsets[feet[0]]) + np.linalg.norm(take.skeleton.offsets[knee])) * unit
    moved = np.linalg.norm(twice.positions() - once.positions(), axis=-1).max(axis=1) * unit  # per frame, m
    assert moved.max() < 0.0125 and moved.max() / leg < 0.0125 and np.percentile(moved, 99) < 0.008
    assert second.contacts == first.contacts and abs(second.mean_correction) < 0.002
    np.testing.assert_array_equal(twice.root[:, [0, 2]], once.root[:, [0, 2]])


def test_a_pin_the_leg_cannot_reach_keeps_the_foot_on_the_floor():
    """The body slides 40 cm in a second over straight legs: the pin (the span's median) is out of the legs'
    reach, so each ankle goes as far towards it as the leg reaches with the foot raised by at most LIFT,
    instead of the straight leg pointing at it and lifting the foot off the floor."""
    from dance_core.motion.grounding import LIFT

    m = dancer(seconds=3.0)
    t = np.arange(m.n_frames) / FPS
    m.root[:, 0] += 0.40 * np.clip(t - 1.0, 0, 1) ** 2 * (3 - 2 * np.clip(t - 1.0, 0, 1))
    out, report = ground(m)
    assert report.contacts == (1, 1)
    assert soles(out).max() < LIFT + 1e-3  # on the floor throughout (soles: the lower foot's)
    h = sole_heights(out, out.positions(end_sites=True), find_feet(out.skeleton), SOLE)
    assert h.max() < LIFT + 1e-3
    assert horizontal_speed(out, 7).max() < horizontal_speed(m, 7).max()  # still pinned as far as it goes


def knee_flexion(motion):
    """Per frame, the mean flexion of both knees in degrees (0: straight)."""
    p = motion.positions()
    out = []
    for hip, knee, ankle in ((1, 4, 7), (2, 5, 8)):
        a, b = p[:, hip] - p[:, knee], p[:, ankle] - p[:, knee]
        cos = (a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
        out.append(180 - np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.mean(out, 0)


def sliding_plie(seconds: float, start: float):
    """The standing dancer in a plié (hips, knees and ankles bent), sliding 20 cm sideways with its feet over
    the second after ``start``."""
    m = dancer(seconds=seconds)
    bend = np.zeros((m.n_frames, 24, 3))
    bend[:, [1, 2], 0], bend[:, [4, 5], 0], bend[:, [7, 8], 0] = -0.4, 0.8, -0.4
    m.rotations[:, [1, 2, 4, 5, 7, 8]] = expmap_to_quat(bend)[:, [1, 2, 4, 5, 7, 8]]
    t = np.arange(m.n_frames) / FPS
    m.root[:, 0] += 0.20 * np.clip(t - start, 0, 1) ** 2 * (3 - 2 * np.clip(t - start, 0, 1))
    return m


def test_pinned_legs_keep_their_knees_bend(monkeypatch):
    """A dancer in a plie slides 20 cm sideways with its feet: pinned, the feet would stretch the legs (the
    knees 2-3 degrees straighter); the pelvis comes down instead, so the knees keep their bend, the feet
    stay on the floor and the body above the legs keeps its pose around the root."""
    from dance_core.motion import grounding

    m = sliding_plie(seconds=3.0, start=1.0)
    before = knee_flexion(m)
    out, report = ground(m)
    assert report.contacts == (1, 1) and report.skating_after < 0.01 * report.skating_before
    assert knee_flexion(out).min() > before.min() - 0.5
    assert np.abs(soles(out)).max() < 1e-3
    np.testing.assert_array_equal(out.root[:, [0, 2]], m.root[:, [0, 2]])
    np.testing.assert_allclose(out.positions()[:, UPPER] - out.root[:, None], m.positions()[:, UPPER] - m.root[:, None],
                               atol=1e-9)
    monkeypatch.setattr(grounding, "MAX_DROP", 0.0)  # the control: no drop, the pins straighten the knees
    stretched, _ = ground(m)
    assert knee_flexion(stretched).min() < before.min() - 2.0
