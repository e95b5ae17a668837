"""Grounding with a look-ahead (dance_core.motion.buffered_grounding): the whole dance's steps on a rolling
buffer give the offline grounding's frames where the buffer sees what offline does, each frame a fixed delay
after it arrives, and a planted foot stays planted as the buffer slides."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_grounding import knee_flexion, sliding_plie  # noqa: E402

from dance_core.motion.buffered_grounding import BufferedGrounding
from dance_core.motion.grounding import GroundingOptions, find_feet, foot_contacts, foot_speeds, ground, soles
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24

FPS = 20.0
L_HIP, R_HIP, L_KNEE, R_KNEE, L_SHOULDER = 1, 2, 4, 5, 16


def stepper(seconds=8.0, lift=0.1, slide=0.15):
    """A dance24 dancer stepping in place, knees bent, each foot up for 0.3 s of every second in turn, the body sliding
    forwards at ``slide`` m/s (its planted feet skate) and floating ``lift`` above the floor."""
    n = int(seconds * FPS)
    t = np.arange(n) / FPS
    rot = np.zeros((n, 24, 3))
    for hip, knee, start in ((L_HIP, L_KNEE, 0.1), (R_HIP, R_KNEE, 0.6)):
        phase = (t - start) % 1.0
        bump = np.where(phase < 0.3, np.sin(np.pi * phase / 0.3) ** 2, 0.0)
        rot[:, hip, 0], rot[:, knee, 0] = -0.3 - 0.7 * bump, 0.6 + 1.2 * bump
    rot[:, L_SHOULDER, 2] = -1.2 + 0.4 * np.sin(2 * np.pi * t)
    root = np.zeros((n, 3))
    root[:, 1] = dance24().rest_positions()[0, 1] + lift
    root[:, 2] = slide * t
    return Motion(dance24(), FPS, root, expmap_to_quat(rot))


def buffered(motion, lookahead, **options):
    """The motion grounded by ``BufferedGrounding``, and the frame index each output came back at."""
    g = BufferedGrounding(motion.skeleton, motion.fps, lookahead, **options)
    out, arrived = [], []
    for i in range(motion.n_frames):
        frame = g.push(motion.root[i], motion.rotations[i])
        if frame is not None:
            out.append(frame)
            arrived.append(i)
    grounded = Motion(motion.skeleton, motion.fps, np.stack([f[0] for f in out]), np.stack([f[1] for f in out]))
    return grounded, np.array(arrived), np.stack([f[2] for f in out])


def test_each_frame_comes_back_grounded_a_fixed_delay_later_as_offline_grounding_has_it():
    m = stepper()
    out, arrived, positions = buffered(m, lookahead=1.0)
    delay = int(round(1.0 * FPS))
    np.testing.assert_array_equal(arrived, np.arange(delay, m.n_frames))  # frame i comes back with frame i + delay
    np.testing.assert_allclose(positions, out.positions(), atol=1e-9)
    offline, report = ground(m)
    assert report.contacts[0] >= 7 and report.contacts[1] >= 7  # spans of 0.7 s, inside the 1-s look-ahead
    # the frames whose floor and contact spans the buffer sees whole (past the first second): offline's, within
    # a few millimetres (the floor and the smoothing see 1 s either way there, not the whole dance)
    n = out.n_frames
    gap = np.linalg.norm(out.positions() - offline.positions()[:n], axis=-1).max(1)
    assert gap[20:].max() < 0.005, gap[20:].max()
    assert np.abs(soles(out)[20:].min(1)).max() < 0.01  # on the floor, lifted 10 cm before
    feet = find_feet(m.skeleton)
    # planted feet do not skate: the contacts offline finds, the ankles' horizontal speed there
    contacts = foot_contacts(soles(offline), foot_speeds(offline.positions(), feet, FPS, vertical=True), FPS,
                             GroundingOptions())[:n]
    speed = foot_speeds(out.positions(), feet, FPS)[contacts]
    raw = foot_speeds(m.positions(), feet, FPS)[: n][contacts]
    assert raw.mean() > 0.1 and speed.mean() < 0.15 * raw.mean(), (raw.mean(), speed.mean())  # 0.15 -> 0.017 m/s


@pytest.mark.parametrize("lookahead", [0.25, 0.5])
def test_a_short_look_ahead_keeps_a_planted_foot_planted_and_the_body_on_the_floor(lookahead):
    """Spans longer than the look-ahead: a span's pin is fixed when its first frame is given out (the median of
    what the buffer holds of it), so a foot that stays down does not move as the buffer slides."""
    m = stepper(seconds=6.0)
    out, arrived, _ = buffered(m, lookahead)
    assert arrived[0] == int(round(lookahead * FPS))
    feet = find_feet(m.skeleton)
    n = out.n_frames
    contacts = foot_contacts(soles(out), foot_speeds(out.positions(), feet, FPS, vertical=True), FPS,
                             GroundingOptions())
    speed = foot_speeds(out.positions(), feet, FPS)[contacts]
    raw = foot_speeds(m.positions(), feet, FPS)[:n][contacts]
    assert contacts.mean() > 0.5 and np.median(speed) < 1e-9 and speed.mean() < 0.15 * raw.mean()
    assert np.abs(soles(out)[20:].min(1)).max() < 0.01
    np.testing.assert_array_equal(out.root[:, [0, 2]], m.root[:n, [0, 2]])  # only the height moves the body


def test_a_skeleton_without_feet_passes_through_after_the_delay():
    from dance_core.motion.skeleton import Skeleton

    skel = Skeleton(["a", "b"], [-1, 0], np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))
    g = BufferedGrounding(skel, FPS, 0.1)
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    got = [g.push(np.array([0.0, float(i), 0.0]), rot) for i in range(5)]
    assert got[:2] == [None, None] and [float(f[0][1]) for f in got[2:]] == [0.0, 1.0, 2.0]


def test_the_height_correction_is_as_smooth_as_offline_and_keeps_every_foot_above_the_floor():
    """A frame's height correction is the mean of those the buffer found for it while it was in the look-ahead:
    the last one alone jumps with what the buffer's end shows (the root's vertical jerk 1.46x offline
    grounding's here; the mean 0.93x), and each keeps every foot above the floor, so the mean does. The knee-keeping
    drop on top (the pins of a sliding stepper stretch its legs) stays about as smooth as offline's."""
    m = stepper()
    t = np.arange(m.n_frames) / FPS
    m.root[:, 1] += 0.04 * np.sin(2 * np.pi * t / 1.7)  # the body bobs: the correction has to follow
    offline, _ = ground(m)
    out, _, _ = buffered(m, 0.25, drop_smoothing=None)

    def jerk(y):
        return np.abs(np.diff(y, 3)).mean() * FPS**3

    assert jerk(out.root[:, 1]) < 1.1 * jerk(offline.root[: out.n_frames, 1])
    assert soles(out).min() > -1e-6
    dropped, _, _ = buffered(m, 0.25)
    assert not np.allclose(dropped.root[:, 1], out.root[:, 1])
    assert jerk(dropped.root[:, 1]) < 1.25 * jerk(offline.root[: out.n_frames, 1])
    assert soles(dropped).min() > -1e-6


def test_pinned_legs_keep_their_knees_bend_live_with_every_foot_on_or_above_the_floor():
    """The plié of the offline test slides 20 cm with its feet: pinned frame by frame, the legs would stretch
    (10 degrees straighter without the drop: live pins stay where each span began); the pelvis comes down through
    the drop's filters instead, the knees keep their bend within 2.5 degrees, and no foot goes below the floor."""
    m = sliding_plie(seconds=4.0, start=1.5)
    before = knee_flexion(m)
    kept, _, _ = buffered(m, 0.1)
    assert knee_flexion(kept).min() > before.min() - 2.5
    assert soles(kept).min() > -1e-6
    control, _, _ = buffered(m, 0.1, drop_smoothing=None)  # the same grounding without the drop
    assert knee_flexion(control).min() < before.min() - 2.0


def test_a_swinging_foot_keeps_its_height_while_the_pelvis_comes_down():
    """Sliding at 0.5 m/s, the planted legs would stretch: the pelvis comes down up to 4 cm. The foot in the air
    keeps the height it has without the drop (its knee bends), where lowering it with the body (3.9 cm, before)
    brought swinging feet down to skim the floor: live skating 1.15-1.37x offline's on the bundled dancers."""
    m = stepper(slide=0.5)
    kept, _, _ = buffered(m, 0.1)
    control, _, _ = buffered(m, 0.1, drop_smoothing=None)
    assert (control.root[:, 1] - kept.root[:, 1]).max() > 0.03  # the pelvis came down
    up = soles(control) > 0.06  # feet in the air
    assert up.sum() > 20
    assert np.abs(soles(kept) - soles(control))[up].max() < 1e-3
    assert soles(kept).min() > -1e-6
