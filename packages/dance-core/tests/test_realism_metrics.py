"""``dance evaluate``'s realism metrics: values on sets whose answer is known, the controls they exist to
fail, and their one-line errors."""

import json

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.errors import DataError
from dance_core.evaluation.realism_metrics import MIN_WINDOWS, BodyLocking, Realism
from dance_core.formats.bvh import BvhFormat
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24
from dance_core.protocols import JointClip

FPS = 30.0
SKEL = dance24()
J = {n: i for i, n in enumerate(SKEL.names)}


def dancer(seed, seconds=30.0, beats=None, amplitude=0.6):
    """Arms and knees swinging between accents (on ``beats`` when given, else at random), travelling."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    t = np.arange(n) / FPS
    accents = np.asarray(beats) if beats is not None else np.cumsum(rng.uniform(0.3, 0.8, int(seconds / 0.3)))
    k = np.clip(np.searchsorted(accents, t, side="right") - 1, 0, len(accents) - 2)
    phase = np.clip((t - accents[k]) / (accents[k + 1] - accents[k]), 0, 1)
    swing = amplitude * np.where(k % 2 == 0, (1 - np.cos(np.pi * phase)) / 2, (1 + np.cos(np.pi * phase)) / 2)
    rot = np.zeros((n, len(SKEL), 3))
    rot[:, J["L_Shoulder"], 2], rot[:, J["R_Shoulder"], 2] = swing + 0.3 * rng.random(), -swing
    rot[:, J["L_Elbow"], 1], rot[:, J["L_Knee"], 0], rot[:, J["R_Knee"], 0] = swing, swing / 2, 0.3 - swing / 3
    root = np.tile(SKEL.offsets[0], (n, 1))
    root[:, 0] += 0.3 * np.sin(0.4 * t + seed)
    motion = Motion(SKEL, FPS, root, expmap_to_quat(rot))
    return motion


def clip(name, motion, beats=None):
    return JointClip(name, motion.positions(), motion.fps, list(SKEL.names), beats)


def still(name, seconds=30.0):
    n = int(seconds * FPS)
    rest = Motion(SKEL, FPS, np.tile(SKEL.offsets[0], (n, 1)), np.tile([0.0, 0, 0, 1], (n, len(SKEL), 1)))
    return clip(name, rest)


def test_a_set_is_near_itself_on_the_scale_of_its_halves_and_far_from_a_still_figure():
    reference = [clip(f"r{s}", dancer(s)) for s in range(4)]
    alike = Realism()([clip(f"g{s}", dancer(s + 10)) for s in range(4)], reference)
    assert alike.values["realism_in_range"] == 11 and np.isfinite(alike.values["realism_scale"])
    assert alike.values["realism_ratio"] < 3
    statue = Realism()([still("s0"), still("s1")], reference)
    assert statue.values["realism"] > 10 * alike.values["realism"] and statue.values["realism_in_range"] < 5
    assert any("elbow_bend median" in n for n in statue.notes)


def test_short_references_get_no_scale_and_say_why():
    reference = [clip("short", dancer(1, seconds=6.0))]  # 5 windows: halves of 1 window
    result = Realism()([clip("g", dancer(2))], reference)
    assert "realism_scale" not in result.values and "realism_ratio" not in result.values
    assert any(f"fewer than {MIN_WINDOWS}" in n for n in result.notes)


def test_body_locking_scores_accents_on_the_beat_and_refuses_a_rigid_figure():
    beats = np.arange(0.3, 30.0, 0.55)
    on = BodyLocking()([clip("on", dancer(0, beats=beats), beats)])
    assert on.values["body_locking"] > 0.9 and on.values["body_locking_control"] < 0.5
    with pytest.raises(DataError, match="accents of its own"):
        BodyLocking()([JointClip("statue", still("x").positions, FPS, list(SKEL.names), beats)])


def test_a_clip_without_joint_names_is_one_line():
    anonymous = JointClip("anon", dancer(0).positions(), FPS, None)
    with pytest.raises(DataError, match="anon: the clip has no joint names"):
        Realism()([anonymous], [anonymous])


def test_dance_evaluate_reports_realism_and_body_locking(tmp_path, capsys):
    beats = np.arange(0.3, 30.0, 0.55)
    for folder, seeds in (("gen", (0, 1)), ("ref", (5, 6, 7))):
        (tmp_path / folder).mkdir()
        for s in seeds:
            motion = dancer(s, beats=beats if folder == "gen" else None)
            BvhFormat().write_motion(motion, tmp_path / folder / f"song{s}.bvh")
    (tmp_path / "gen" / ".song0.outputs.json").write_text("{}")  # compose's manifest is not a motion file
    (tmp_path / "music").mkdir()
    for s in (0, 1):
        (tmp_path / "music" / f"song{s}.beats").write_text("".join(f"{b:.3f}\n" for b in beats))
    code = main(["-q", "evaluate", "--generated", str(tmp_path / "gen"), "--reference", str(tmp_path / "ref"),
                 "--music", str(tmp_path / "music"), "--metrics", "realism", "body-locking", "--no-plots",
                 "-o", str(tmp_path / "r.json"), "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert report["values"]["realism_in_range"] >= 9 and report["values"]["body_locking"] > 0.9
    assert report["tracker"] == "flux" and any("beat annotation files" in n for n in report["notes"])
