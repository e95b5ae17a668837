"""Kinematic move detectors: hand-built bodies that do and do not perform each move, and agreement with
the synthetic dancer's own move labels."""

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.evaluation import move_detect as md
from dance_core.motion.skeletons import dance24

REST = dance24().rest_positions()


FPS = 30.0


def still(seconds: float = 6.0) -> np.ndarray:
    """The rest pose (T-pose, facing +Z, feet 3 cm above the floor) held for ``seconds``."""
    pose = REST - np.array([0.0, REST[:, 1].min() - 0.03, 0.0])
    return np.repeat(pose[None], int(seconds * FPS), axis=0).copy()


def arms_down(p: np.ndarray) -> np.ndarray:
    """Wrists and hands hanging beside the hips."""
    for side, (w, h) in ((1, (md.L_WRIST, md.L_HAND)), (-1, (md.R_WRIST, md.R_HAND))):
        p[:, w] = p[:, md.PELVIS] + [side * 0.25, 0.0, 0.0]
        p[:, h] = p[:, md.PELVIS] + [side * 0.25, -0.08, 0.0]
    return p


def turned(p: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Each frame turned by ``yaw`` (radians, about +Y) about its pelvis."""
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    rel = p - p[:, :1]
    x, z = rel[..., 0], rel[..., 2]
    out = rel.copy()
    out[..., 0], out[..., 2] = c * x + s * z, -s * x + c * z
    return out + p[:, :1]


def seconds_with(move: str, p: np.ndarray) -> np.ndarray:
    return md.second_hits(md.detect(move, p, FPS), FPS)


def test_a_still_body_performs_no_move():
    p = arms_down(still())
    for move in md.DETECTORS:
        assert not md.detect(move, p, FPS).any(), move


def test_jump_needs_both_feet_up_and_the_pelvis_raised():
    p = arms_down(still())
    t = np.arange(len(p)) / FPS
    hop = np.where((t % 1.0) < 0.3, 0.12, 0.0)  # a 12 cm hop at the start of every second
    jumping = p + hop[:, None, None] * np.array([0.0, 1.0, 0.0])
    assert seconds_with("jump", jumping).all()
    one_foot = jumping.copy()
    one_foot[:, [md.L_ANKLE, md.L_FOOT], 1] = p[:, [md.L_ANKLE, md.L_FOOT], 1]  # one foot stays down
    assert not md.detect("jump", one_foot, FPS).any()


def test_spin_on_the_spot_but_not_a_walk_round_a_circle():
    p = arms_down(still(4.0))
    t = np.arange(len(p)) / FPS
    spin = turned(p, 2 * np.pi * t / 1.5)  # a turn every 1.5 s
    assert seconds_with("spin", spin).mean() > 0.7
    assert np.degrees(np.ptp(md.facing(spin))) == pytest.approx(360 * 4 / 1.5, rel=0.02)
    walk = turned(p, 2 * np.pi * t / 1.5)  # the same turning while walking a circle of 1.5 m radius
    walk += (1.5 * np.stack([np.sin(2 * np.pi * t / 1.5), 0 * t, np.cos(2 * np.pi * t / 1.5)], 1))[:, None]
    assert not md.detect("spin", walk, FPS).any()


def test_clap_is_a_fast_approach_of_the_hands_in_front():
    p = arms_down(still())
    t = np.arange(len(p)) / FPS
    gap = 0.05 + 0.25 * (1 - np.cos(2 * np.pi * t / 0.5))  # 5-55 cm, together twice a second
    chest = p[:, md.PELVIS] + [0.0, 0.35, 0.4]
    clapping = p.copy()
    for side, w, h in ((1, md.L_WRIST, md.L_HAND), (-1, md.R_WRIST, md.R_HAND)):
        clapping[:, h] = chest + side * gap[:, None] / 2 * np.array([1.0, 0.0, 0.0])
        clapping[:, w] = clapping[:, h] - [0.0, 0.0, 0.08]
    assert seconds_with("clap", clapping).all()
    held = clapping.copy()
    hands = [md.L_HAND, md.R_HAND, md.L_WRIST, md.R_WRIST]
    held[:, hands] = clapping[:1, hands]
    assert not md.detect("clap", held, FPS).any()  # hands held together: no approach
    behind = clapping.copy()
    behind[:, hands, 2] -= 0.8  # the same behind the back
    assert not md.detect("clap", behind, FPS).any()


def test_kick_and_arms_up():
    p = arms_down(still())
    kick = p.copy()
    kick[::15, md.L_ANKLE] += [0.0, 0.3, 0.5]  # the left foot up in front twice a second
    assert seconds_with("kick", kick).all()
    back = p.copy()
    back[::15, md.L_ANKLE] += [0.0, 0.3, -0.5]  # lifted behind: not a forward kick
    assert not md.detect("kick", back, FPS).any()
    up = p.copy()
    up[:, [md.L_WRIST, md.R_WRIST], 1] = p[:, [md.HEAD], 1] + 0.2
    assert md.detect("arm-wave", up, FPS).all()
    assert not md.detect("arm-wave", still(), FPS).any()  # a T-pose: wrists at shoulder height
    ahead = up.copy()
    ahead[:, [md.L_WRIST, md.R_WRIST], 2] += 0.6  # raised but reaching out in front
    assert not md.detect("arm-wave", ahead, FPS).any()


def test_shares_of_seconds_and_bad_input():
    hits = np.zeros(90, bool)
    hits[40] = True  # in the second 1-2 s
    assert md.move_share(hits, FPS) == pytest.approx(1 / 3)
    assert md.move_share(hits, FPS, 0.0, 1.0) == 0.0
    assert np.isnan(md.move_share(hits, FPS, 2.5, 3.0))
    with pytest.raises(DataError, match="SMPL-24"):
        md.detect("jump", np.zeros((10, 22, 3)), FPS)
    with pytest.raises(DataError, match="no detector"):
        md.detect("moonwalk", still(1.0), FPS)


def test_the_detectors_agree_with_the_synthetic_dancers_labels():
    from dance_core.synth.dancer import PHRASINGS
    from dance_core.synth.synthetic_dance import make_clip

    label_of = {t: m for m, ts in PHRASINGS.items() for t in ts}
    found = {m: [0, 0] for m in md.DETECTORS}  # seconds the move covers, of them detected
    false = {m: 0 for m in md.DETECTORS}  # detections in seconds the move does not touch
    for i in range(40, 46):
        clip = make_clip(i, seed=0, seconds=40.0, bpm=(70.0, 180.0), rate=8000, fps=FPS)
        p = clip.motion.skeleton_motion.positions()
        secs = int(len(p) // FPS)
        for m in md.DETECTORS:
            cover = np.zeros(secs)
            for span in clip.texts:
                if label_of[span.text] == m:
                    cover += [max(0.0, min(s + 1, span.end) - max(s, span.start)) for s in range(secs)]
            hits = seconds_with(m, p)[:secs]
            found[m][0] += int((cover[: len(hits)] >= 0.5).sum())
            found[m][1] += int((hits & (cover[: len(hits)] >= 0.5)).sum())
            false[m] += int((hits & (cover[: len(hits)] == 0)).sum())
    total = sum(v[0] for v in found.values())
    assert total > 50
    assert sum(v[1] for v in found.values()) >= 0.9 * total  # recall over all moves
    assert sum(false.values()) <= 0.1 * total
