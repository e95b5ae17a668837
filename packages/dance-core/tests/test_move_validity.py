"""move-validity: the synthetic dancer's own dances are valid bar by bar; noise, a frozen pose and (mostly)
a dance played backwards are not."""

from pathlib import Path

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.evaluation.move_validity import MoveValidity
from dance_core.protocols import JointClip
from dance_core.synth.synthetic_dance import make_clip

KW = {"seconds": 8.0, "bpm": (80.0, 140.0), "rate": 8000, "fps": 30.0}


def joint_clip(source, positions=None, music=True) -> JointClip:
    """A generated clip's joint positions with (or without) its song's beats."""
    p = source.motion.skeleton_motion.positions() if positions is None else positions
    return JointClip(source.name, p, KW["fps"], None, np.asarray(source.meta["beats"]) if music else None)


@pytest.fixture(scope="module")
def dances():
    """Sixteen songs, each with one dance by a dancer drawn from all of them."""
    return [make_clip(i, seed=0, dancers=None, **KW) for i in range(16)]


def test_the_generators_dances_are_valid_and_backwards_they_mostly_are_not(dances):
    metric = MoveValidity()
    own = metric([joint_clip(c) for c in dances])
    assert len({c.meta["dancer"] for c in dances}) >= 5
    assert own.values["move_validity"] >= 0.9 and own.values["move_distance"] < 0.02
    assert own.values["move_bars"] == sum(v["bars"] for v in own.per_clip.values())
    # played backwards to the same beats: most moves are time-symmetric (a bounce backwards is a bounce),
    # so what gives it away is where its accents fall, how it blends, walks, waves and hits
    backwards = metric([joint_clip(c, c.motion.skeleton_motion.positions()[::-1].copy()) for c in dances])
    assert backwards.values["move_validity"] <= 0.5
    assert backwards.values["move_distance"] > 1.5 * own.values["move_distance"]
    # without the music, bars come from the dance's own kinematic beats
    kinematic = metric([joint_clip(c, music=False) for c in dances[:6]])
    assert kinematic.values["move_validity"] >= 0.9
    assert any("kinematic beats" in n for n in kinematic.notes)


def test_noise_and_a_frozen_pose_are_not_moves(dances):
    metric = MoveValidity()
    rng = np.random.default_rng(0)
    clips = [joint_clip(c) for c in dances[:3]]
    jitter = [JointClip(c.name, c.positions + rng.normal(0.0, 0.03, c.positions.shape), c.fps, None, c.music_beats)
              for c in clips]
    frozen = [JointClip(c.name, np.repeat(c.positions[:1], len(c.positions), 0), c.fps, None, c.music_beats)
              for c in clips]
    assert metric(jitter).values["move_validity"] == 0.0
    held = metric(frozen)
    assert held.values["move_validity"] == 0.0 and held.values["move_distance"] > 0.04
    assert all(v["still_bars"] == v["bars"] for v in held.per_clip.values())
    still = metric([JointClip(c.name, c.positions, c.fps) for c in frozen])  # no music, no beat in the motion
    assert still.values["move_validity"] == 0.0 and any("nominal 120 bpm" in n for n in still.notes)


def test_where_and_which_way_the_dancer_faces_does_not_count(dances):
    clip = joint_clip(dances[1])
    yaw = 1.1
    turn = np.array([[np.cos(yaw), 0.0, np.sin(yaw)], [0.0, 1.0, 0.0], [-np.sin(yaw), 0.0, np.cos(yaw)]])
    moved = JointClip("moved", clip.positions @ turn.T + np.array([3.0, 0.0, -2.0]), clip.fps, None, clip.music_beats)
    a, b = MoveValidity()([clip]), MoveValidity()([moved])
    assert a.values["move_distance"] == pytest.approx(b.values["move_distance"], abs=1e-4)


def test_registered_configured_and_skipping_other_skeletons(dances):
    from pydantic import ValidationError

    from dance_core.evaluation.configs import MoveValidityConfig
    from dance_core.evaluation.report import evaluate

    clips = [joint_clip(c) for c in dances[:2]]
    six = JointClip("six", np.zeros((100, 6, 3)), 30.0, None, np.arange(0.5, 3.0, 0.5))
    report = evaluate([*clips, six], None, ["move-validity"], options={"move-validity": {"threshold": 0.05}})
    result = report.results["move-validity"]
    assert set(result.values) == {"move_validity", "move_distance", "move_bars"}
    assert result.values["move_validity"] > 0.9
    assert set(result.per_clip) == {c.name for c in clips} and any("six" in n and "24 SMPL" in n for n in result.notes)
    with pytest.raises(DataError, match="no clip"):
        MoveValidity()([six])
    with pytest.raises(ValidationError, match="2-7"):
        MoveValidityConfig(meters=[8])


def test_the_detector_does_not_use_the_generators_choice_of_moves():
    import dance_core.evaluation.move_validity as mv

    source = Path(mv.__file__).read_text()
    for name in ("choose_moves", "phrase_moves", "routine", "SECTION_WEIGHTS", "chain", "perform_dance"):
        assert name not in source
