"""Live, the figure rests when the music stops: silence found as audio arrives (dance_core.live.silence), a
person standing at ease on any rig (dance_core.motion.standing) and poses blended toward it without a jump
(dance_core.live.rest)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.live.rest import RestBlend
from dance_core.live.silence import AHEAD, EASE_OUT, FLOOR_DB, HOLD, MEMORY, SilenceGate
from dance_core.motion.fk import joint_positions
from dance_core.motion.grounding import soles
from dance_core.motion.motion import Motion
from dance_core.motion.rig_maps import rig_map
from dance_core.motion.rotations import expmap_to_quat, quat_mul, yaw_quat
from dance_core.motion.skeletons import body25, dance24, transflower21
from dance_core.motion.standing import standing_pose

CMU = Path(__file__).resolve().parents[3] / ".." / "shared" / "fixtures" / "bvh" / "cmu_01_01.bvh"
RATE, FPS = 8000, 20.0


def _rigs():
    rigs = [dance24(), transflower21()]
    if CMU.exists():
        from dance_core.api import read_motion

        rigs.append(read_motion(str(CMU)).skeleton_motion.skeleton)
    return rigs


@pytest.mark.parametrize("skeleton", _rigs(), ids=lambda s: s.name)
def test_standing_hangs_the_arms_by_the_sides_and_stands_on_the_floor(skeleton):
    root, rotations = standing_pose(skeleton)
    p = joint_positions(skeleton, root, rotations)
    j = rig_map(skeleton).joints
    leg = np.linalg.norm(p[j["L_Hip"]] - p[j["L_Ankle"]])
    for side in "LR":
        shoulder, elbow, wrist = (p[j[f"{side}_{n}"]] for n in ("Shoulder", "Elbow", "Wrist"))
        upper, lower = elbow - shoulder, wrist - elbow
        down = -upper[1] / np.linalg.norm(upper)
        assert np.degrees(np.arccos(down)) == pytest.approx(np.hypot(8.0, 4.0), abs=0.5)  # the arm hangs down
        bend = np.degrees(np.arccos(upper @ lower / np.linalg.norm(upper) / np.linalg.norm(lower)))
        assert bend == pytest.approx(14.0, abs=0.5) and lower[2] > upper[2] / np.linalg.norm(upper)  # bent forward
        assert wrist[1] < p[j["Pelvis"]][1] + 0.2 * leg  # the hands by the hips, not out at shoulder height
        assert abs(wrist[0] - p[j["Pelvis"]][0]) < 0.5 * leg
    h = soles(Motion(skeleton, 30.0, root[None], rotations[None]))
    assert h.min() == pytest.approx(0.0, abs=1e-9)  # on the floor
    assert p[j["Head"]][1] > p[j["L_Shoulder"]][1] > p[j["Pelvis"]][1] > p[j["L_Knee"]][1]  # upright


def test_a_rig_standing_cannot_map_is_one_line():
    with pytest.raises(DataError, match="body25"):
        standing_pose(body25())


def _tone(seconds: float, db: float) -> np.ndarray:
    t = np.arange(int(seconds * RATE)) / RATE
    return (10 ** (db / 20) * np.sqrt(2) * np.sin(2 * np.pi * 220 * t)).astype(np.float32)


def _weights(audio: np.ndarray, block: int, look: int = 8) -> np.ndarray:
    """Each frame's rest weight, the audio pushed in blocks of ``block`` samples and each frame's weight asked
    once the audio to ``look`` frames past it has arrived."""
    gate, out = SilenceGate(FPS, RATE), []
    for lo in range(0, len(audio), block):
        gate.push(audio[lo : lo + block])
        heard = (lo + len(audio[lo : lo + block])) * FPS / RATE
        while len(out) + look + 1 <= heard:
            out.append(gate.weight(len(out), len(out) + look))
    return np.array(out)


def test_the_figure_rests_in_a_pause_not_in_a_breath_and_resumes_before_the_music():
    # music at -20 dBFS, a breath of 0.3 s, music, 3 s of a quiet room (-70 dBFS), music again
    parts = [_tone(3, -20), _tone(0.3, -90), _tone(3, -20), _tone(3, -70), _tone(3, -20)]
    audio = np.concatenate(parts)
    w = _weights(audio, 441)
    t = np.arange(len(w)) / FPS
    assert np.all(w[t < 6.3] == 0.0)  # the breath does not stop the dance
    pause = (t >= 6.3) & (t < 9.3)
    assert np.all(w[(t > 6.3 + HOLD + 1.0) & (t < 9.3 - AHEAD)] == 1.0)  # at rest within HOLD + EASE_IN
    assert np.all(w[pause & (t < 6.3 + HOLD)] == 0.0)
    back = int(round(9.3 * FPS))
    assert w[back] < 0.5 and w[back - int(AHEAD * FPS) - 1] == 1.0  # it turns back to the dance before the music
    assert np.all(w[back + int(EASE_OUT * FPS) :] == 0.0)
    assert np.abs(np.diff(w)).max() <= 1.5 / (EASE_OUT * FPS) + 1e-9  # eased: no jump
    # the same audio in any blocks gives the same rests
    assert np.array_equal(w, _weights(audio, 4000)[: len(w)]) and np.array_equal(w, _weights(audio, 37)[: len(w)])


def test_silence_is_quiet_against_the_loudest_second_heard_and_off_means_never():
    # a quiet recording (-50 dBFS) is music; after loud music (-5 dBFS) a -50 dBFS hiss is a pause
    quiet = _weights(np.concatenate([_tone(3, -50), _tone(3, -50)]), 441)
    assert quiet.max() == 0.0
    loud = _weights(np.concatenate([_tone(3, -5), _tone(3, -50)]), 441)
    assert loud[-1] == 1.0 and loud[: int(3 * FPS)].max() == 0.0
    gate = SilenceGate(FPS, RATE, None)
    gate.push(np.zeros(RATE * 3, np.float32))
    assert gate.weight(40, 48) == 0.0 and FLOOR_DB == -70.0
    # hours hold no more than a minute: the silence of the last MEMORY seconds is kept
    gate = SilenceGate(FPS, RATE)
    for _ in range(30):
        gate.push(np.concatenate([_tone(4, -20), _tone(4, -90)]))
    assert gate.frames == 30 * 8 * FPS and len(gate.silence) == MEMORY * FPS
    assert gate.weight(int(gate.frames - 0.5 * FPS), gate.frames) > 0 and not gate.silent(0)


def _travelling(n: int, skeleton) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A figure walking 1 m/s along x, turning 90 degrees a second and swinging its limbs."""
    rng = np.random.default_rng(0)
    t = np.arange(n) / FPS
    axes = rng.normal(size=(len(skeleton), 3))
    rotations = expmap_to_quat(0.4 * np.sin(2 * np.pi * t)[:, None, None] * axes[None])
    rotations[:, 0] = quat_mul(yaw_quat(np.pi / 2 * t), rotations[:, 0])
    root = np.stack([t, 0.95 + 0.03 * np.sin(4 * np.pi * t), np.zeros(n)], 1)
    positions = np.stack([joint_positions(skeleton, root[i], rotations[i]) for i in range(n)])
    return root, rotations, positions


def test_poses_come_to_rest_where_they_are_and_dance_on_from_there_without_a_jump():
    skeleton = dance24()
    n = 160
    root, rotations, positions = _travelling(n, skeleton)
    ramp = np.clip(np.r_[np.zeros(20), np.arange(1, 21) / 20, np.ones(60), 1 - np.arange(1, 9) / 8, np.zeros(52)],
                   0, 1)
    blend = RestBlend(skeleton)
    out = [blend(root[i], rotations[i], positions[i], ramp[i], i / 30.0) for i in range(n)]
    shown = np.stack([o[2] for o in out])
    assert np.array_equal(shown[:20], positions[:20])  # no rest yet: unchanged
    still, j = shown[40:100], rig_map(skeleton).joints
    ankles = [j["L_Ankle"], j["R_Ankle"]]
    assert np.abs(still[:, ankles] - still[0, ankles]).max() < 2e-3  # at rest it stands where it is; the dance goes on
    assert 1e-4 < np.abs(still - still[0]).max() < 0.03  # breathing and swaying a little (dance_core.motion.idle)
    stand_root, stand = standing_pose(skeleton)
    assert still[0][:, 1].min() == pytest.approx(joint_positions(skeleton, stand_root, stand)[:, 1].min(), abs=2e-3)
    steps = np.linalg.norm(np.diff(shown, axis=0), axis=2).max(1)
    danced = np.linalg.norm(np.diff(positions, axis=0), axis=2).max(1)
    assert steps.max() < 2.5 * danced.max()  # no jump going to rest or coming back
    assert np.linalg.norm(shown[40, 0, [0, 2]] - positions[40, 0, [0, 2]]) > 0.5  # it stopped; the dance went on
    # after the rest: the dance's own movement, turned and shifted (a rigid move about the vertical)
    after, source = shown[110:], positions[110:]
    d = lambda p: np.linalg.norm(p[:, :, None] - p[:, None], axis=-1)  # noqa: E731 - pairwise joint distances
    assert np.abs(d(after) - d(source)).max() < 1e-9
    assert np.abs(np.diff(after[:, :, 1], axis=0) - np.diff(source[:, :, 1], axis=0)).max() < 1e-9
    walked = [np.linalg.norm(np.diff(p[:, 0, [0, 2]], axis=0), axis=1) for p in (after, source)]
    assert np.abs(walked[0] - walked[1]).max() < 1e-9 and walked[0].min() > 0.04  # it walks on at its pace


def test_dance_live_silence_takes_a_level_or_off_and_refuses_other_values_in_one_line(capsys):
    from dance_core.cli.main import build_parser

    parser = build_parser()
    base = ["live", "default", "--input", "-", "--output", "-"]
    assert parser.parse_args(base).silence == FLOOR_DB
    assert parser.parse_args([*base, "--silence", "off"]).silence is None
    assert parser.parse_args([*base, "--silence", "-45"]).silence == -45.0
    for bad in ("5", "loud", "nan"):
        with pytest.raises(SystemExit):
            parser.parse_args([*base, "--silence", bad])
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert "--silence" in err and bad in err
