"""Retargeting between rigs: round trips, rest-pose and unit differences, real mocap onto our skeleton,
joint maps, and the one-line errors for rigs that cannot be mapped."""

from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.errors import DataError
from dance_core.formats.bvh import BvhFormat
from dance_core.motion.ik import rotation_between
from dance_core.motion.motion import Motion
from dance_core.motion.retarget import retarget, rig_frames
from dance_core.motion.rig_maps import PRESETS, arms_lowered, renamed, rig_map
from dance_core.motion.rotations import expmap_to_quat, quat_conj, quat_mul, quat_rotate
from dance_core.motion.skeleton import Skeleton
from dance_core.motion.skeletons import dance24

CMU = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"
needs_cmu = pytest.mark.skipif(not CMU.exists(), reason="../shared/fixtures/bvh/cmu_01_01.bvh not available")


def cmu_take(frames=240):
    return BvhFormat().read_motion(CMU).crop(0, frames)


def with_thumb(skel: Skeleton) -> Skeleton:
    """The skeleton with an extra joint (a thumb on the left hand) that no map knows."""
    hand = skel.names.index("mixamorig:LeftHand")
    return Skeleton(skel.names + ["mixamorig:LeftHandThumb1"], skel.parents + [hand],
                    np.vstack([skel.offsets, [0.02, -0.01, 0.03]]), end_sites=skel.end_sites, units=skel.units,
                    name=skel.name)


def dancing(skel: Skeleton, n=90, fps=30.0, seed=0) -> Motion:
    """Smooth random joint rotations and a travelling root on ``skel`` (rest pose, feet on the floor)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    amp = rng.uniform(0.1, 0.5, (1, len(skel), 3))
    phase = rng.uniform(0, 2 * np.pi, (1, len(skel), 3))
    rot = expmap_to_quat(amp * np.sin(2 * np.pi * 0.7 * t[:, None, None] + phase))
    root = skel.offsets[0] + np.stack([0.3 * t, 0.03 * np.sin(4 * t), 0.2 * t], axis=1)
    return Motion(skel, fps, root, rot)


def assert_same_up_to_floor(positions, expected):
    """Equal but for one vertical shift (retargeting stands the result on the source's floor: the
    lowest its feet go)."""
    shift = positions - expected
    np.testing.assert_allclose(shift[..., [0, 2]], 0.0, atol=1e-8)
    np.testing.assert_allclose(shift[..., 1], shift[0, 0, 1], atol=1e-8)


def world_rotation(motion: Motion, j: int) -> np.ndarray:
    from dance_core.motion.fk import forward_kinematics

    return forward_kinematics(motion.skeleton, motion.root, motion.rotations)[1][:, j]


def bone_directions(motion: Motion, rmap, pairs):
    pos = motion.positions()
    out = []
    for a, b in pairs:
        d = pos[:, rmap.joints[b]] - pos[:, rmap.joints[a]]
        out.append(d / np.linalg.norm(d, axis=-1, keepdims=True))
    return np.stack(out, axis=1)


BONES = [("Pelvis", "Spine1"), ("L_Hip", "L_Knee"), ("R_Knee", "R_Ankle"), ("L_Shoulder", "L_Elbow"),
         ("R_Elbow", "R_Wrist"), ("L_Wrist", "L_Hand"), ("Neck", "Head"), ("L_Ankle", "L_Foot")]


def test_same_body_in_other_units_pose_and_names_moves_the_same():
    """dance24 onto itself in centimetres, in an A-pose, with Mixamo names and an extra joint: every
    joint's trajectory per leg length is the source's (no grounding, so nothing else changes it)."""
    source = dancing(dance24())
    rig = with_thumb(renamed(arms_lowered(dance24()), "mixamo", "mixamorig:")).scaled(100.0, "cm")
    out, report = retarget(source, rig, ground=False)
    assert report.source_map == "smpl" and report.target_map == "mixamo"
    assert report.scale == pytest.approx(100.0) and report.unmapped_target == ["mixamorig:LeftHandThumb1"]
    assert_same_up_to_floor(out.positions()[:, :24] / 100.0, source.positions())
    np.testing.assert_allclose(out.rotations[:, 24], np.tile([0, 0, 0, 1.0], (len(out.rotations), 1)), atol=1e-9)
    np.testing.assert_allclose(out.root[:, [0, 2]] / 100.0, source.root[:, [0, 2]], atol=1e-9)


def test_round_trip_a_to_b_to_a_gives_the_source_back():
    source = dancing(dance24(), seed=3)
    rig = renamed(arms_lowered(dance24()), "unreal").scaled(0.8)
    there, _ = retarget(source, rig, ground=False)
    back, _ = retarget(there, dance24(), ground=False)
    assert_same_up_to_floor(back.positions(), source.positions())
    np.testing.assert_allclose(np.abs((back.rotations * source.rotations).sum(-1)), 1.0, atol=1e-8)


@needs_cmu
def test_cmu_take_onto_our_skeleton_and_back():
    """A real CMU take (cgspeed names, inches-like units, other proportions) onto dance24 and back:
    every mapped bone points the same way as the source's in every frame, the feet stand on the floor
    without skating, and the round trip restores the take's mapped joints."""
    take = cmu_take()
    src = rig_map(take.skeleton)
    assert src.name == "cmu"
    out, report = retarget(take, dance24())
    assert out.skeleton.same_topology(dance24()) and out.n_frames == take.n_frames and out.fps == take.fps
    dst = rig_map(out.skeleton)
    arms = [("L_Collar", "L_Shoulder"), ("R_Collar", "R_Shoulder"), ("L_Shoulder", "L_Elbow"),
            ("R_Elbow", "R_Wrist"), ("L_Elbow", "L_Wrist"), ("L_Wrist", "L_Hand")]
    rest = take.skeleton.rest_positions()
    arms = [(a, b) for a, b in arms if np.linalg.norm(rest[src.joints[a]] - rest[src.joints[b]]) > 1e-6]
    assert len(arms) >= 5
    angle = np.degrees(np.arccos(np.clip((bone_directions(take, src, arms)
                                          * bone_directions(out, dst, arms)).sum(-1), -1, 1)))
    assert angle.max() < 1e-4  # limbs point where the take's do (grounding changes only the legs)
    # the torso turns as the take's does: one fixed rest alignment (the rigs' facings differ a little)
    for c in ("Pelvis", "Spine2", "Spine3"):
        rel = quat_mul(quat_conj(world_rotation(take, src.joints[c])), world_rotation(out, dst.joints[c]))
        np.testing.assert_allclose(np.abs((rel * rel[:1]).sum(-1)), 1.0, atol=1e-9)
        assert abs(rel[0, 3]) > np.cos(np.radians(5) / 2)
    # the feet stand where the take's stand, above its floor (the lowest its feet go), per leg length
    low = out.positions(end_sites=True)[..., 1].min(axis=1) / rig_frames(dance24()).leg
    low_take = take.positions(end_sites=True)[..., 1].min(axis=1)
    low_take = (low_take - np.percentile(low_take, 2)) / rig_frames(take.skeleton).leg
    assert abs(np.median(low) - np.median(low_take)) < 0.03 and low.min() > -0.02
    assert "skating" in report.grounding
    back, _ = retarget(out, take.skeleton, ground=False)
    angle = np.degrees(np.arccos(np.clip((bone_directions(take, src, arms)
                                          * bone_directions(back, src, arms)).sum(-1), -1, 1)))
    assert angle.max() < 1e-4


@needs_cmu
def test_travel_and_height_scale_with_leg_length():
    take = cmu_take()
    out, report = retarget(take, dance24(), ground=False)
    src, dst = rig_frames(take.skeleton), rig_frames(dance24())
    assert report.scale == pytest.approx(dst.leg / src.leg)
    hips = lambda m, f: m.positions()[:, [f.map.joints["L_Hip"], f.map.joints["R_Hip"]]].mean(1)  # noqa: E731
    travel_src = np.diff(hips(take, src)[:, [0, 2]], axis=0) / src.leg
    travel_dst = np.diff(hips(out, dst)[:, [0, 2]], axis=0) / dst.leg
    np.testing.assert_allclose(travel_dst, travel_src, atol=1e-9)


def test_yaml_map_names_a_custom_rig(tmp_path):
    names = {"Pelvis": "root_hips", "L_Knee": "knee_left", "R_Knee": "knee_right"}
    skel = dance24()
    custom = Skeleton([names.get(n, n.lower()) for n in skel.names], skel.parents, skel.offsets,
                      end_sites=skel.end_sites, name="custom")
    with pytest.raises(DataError, match="lacks|finds no joint"):
        rig_map(custom)
    lowered = {n: n.lower() for n in skel.names if n not in names}
    spec = tmp_path / "map.yaml"
    spec.write_text("joints:\n" + "".join(f"  {k}: {v}\n" for k, v in (names | lowered).items()), encoding="utf-8")
    found = rig_map(custom, spec)
    assert found.joints["Pelvis"] == 0 and found.joints["L_Knee"] == skel.names.index("L_Knee")
    out, _ = retarget(dancing(skel), custom, target_map=spec, ground=False)
    assert_same_up_to_floor(out.positions(), dancing(skel).positions())
    bad = tmp_path / "bad.yaml"
    bad.write_text("Knee_Left: knee_left\n", encoding="utf-8")
    with pytest.raises(DataError, match="not a canonical joint"):
        rig_map(custom, bad)


def test_a_rig_without_feet_is_one_line_naming_joints_and_presets():
    skel = dance24()
    keep = [j for j, n in enumerate(skel.names) if "Ankle" not in n and "Foot" not in n]
    legless = Skeleton([skel.names[j] for j in keep], [keep.index(skel.parents[j]) if j else -1 for j in keep],
                       skel.offsets[keep], name="legless")
    with pytest.raises(DataError) as err:
        retarget(dancing(skel), legless)
    text = str(err.value)
    assert "\n" not in text and "L_Ankle" in text and "R_Ankle" in text
    assert all(p in text for p in PRESETS)


def test_zero_length_bone_is_a_clear_error():
    skel = dance24()
    offsets = skel.offsets.copy()
    for name in ("L_Elbow", "L_Wrist", "L_Hand"):  # the whole arm collapsed onto the shoulder
        offsets[skel.names.index(name)] = 0.0
    broken = Skeleton(skel.names, skel.parents, offsets, name="broken")
    with pytest.raises(DataError, match="zero-length bone"):
        rig_frames(broken)


@needs_cmu
def test_cli_retargets_and_writes_nothing_on_failure(tmp_path, capsys):
    take = tmp_path / "take.bvh"
    BvhFormat().write_motion(cmu_take(120), take)
    out = tmp_path / "out.bvh"
    assert main(["-q", "retarget", str(take), "--to", "dance24", "-o", str(out)]) == 0
    written = BvhFormat().read_motion(out)
    assert written.skeleton.permutation_to(dance24()) is not None and written.n_frames == 120
    rig = tmp_path / "mixamo.bvh"
    mixamo = renamed(arms_lowered(dance24()), "mixamo", "mixamorig:").scaled(100.0, "cm")
    BvhFormat().write_motion(Motion(mixamo, 30.0, mixamo.offsets[:1], np.tile([0, 0, 0, 1.0], (1, 24, 1))), rig)
    on_rig = tmp_path / "on-rig.bvh"
    assert main(["-q", "retarget", str(out), "--to", str(rig), "-o", str(on_rig), "--fps", "30"]) == 0
    moved = BvhFormat().read_motion(on_rig)
    assert moved.skeleton.names[0] == "mixamorig:Hips" and moved.fps == 30 and moved.n_frames == 30
    capsys.readouterr()
    nowhere = tmp_path / "never.bvh"
    legless = tmp_path / "legless.bvh"
    legless.write_text("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition "
                       "Zrotation Xrotation Yrotation\n End Site\n {\n  OFFSET 0 10 0\n }\n}\nMOTION\nFrames: 1\n"
                       "Frame Time: 0.0333\n0 0 0 0 0 0\n", encoding="utf-8")
    assert main(["retarget", str(take), "--to", str(legless), "-o", str(nowhere)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "L_Hip" in err and "mixamo" in err
    assert f"{legless}:2:" in err  # file:LINE of the rig's root
    mismatched = tmp_path / "mismatched.bvh"
    mismatched.write_text(rig.read_text().replace("Frames: 1", "Frames: 2") + "0 0 0\n", encoding="utf-8")
    assert main(["retarget", str(take), "--to", str(mismatched), "-o", str(nowhere)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{mismatched}:" in err and "channels" in err
    collapsed = tmp_path / "collapsed.bvh"
    text = BvhFormat().read_motion(rig)
    arm = text.skeleton.names.index("mixamorig:LeftForeArm")
    lines = rig.read_text().splitlines()
    at = text.skeleton.lines[arm]
    for k in range(at, at + 40):  # the forearm, hand and hand-middle offsets collapsed onto the shoulder
        if lines[k].strip().startswith("OFFSET"):
            lines[k] = lines[k].split("OFFSET")[0] + "OFFSET 0 0 0"
        if "End Site" in lines[k]:
            break
    collapsed.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert main(["retarget", str(take), "--to", str(collapsed), "-o", str(nowhere)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "zero-length" in err and f"{collapsed}:" in err
    assert not nowhere.exists()


def test_rotation_helper_sanity():
    """The frames are built from shortest arcs and orthonormal bases: a quick check of the helper used."""
    q = rotation_between(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    np.testing.assert_allclose(quat_rotate(q, np.array([1.0, 0, 0])), [0, 1, 0], atol=1e-12)
