"""Choreography from real moves: a motion graph cut at the dancer's accents, walked to a song's beats."""

from pathlib import Path

import numpy as np
import pytest

from dance_core.errors import DataError
from dance_core.evaluation.realism import body_locking
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24
from dance_core.synth.motion_graph import MotionGraph, real_dance

FPS = 30.0
SKEL = dance24()
J = {n: i for i, n in enumerate(SKEL.names)}
MOCAP = Path(__file__).resolve().parents[3] / ".." / "shared" / "mocap" / "cmu-dance"


def take(seconds, period, seed, travel=0.3):
    """A 'recorded' dancer: limbs swinging out and back with a pause every ``period`` s (its accents),
    gliding forward at ``travel`` m/s, at its own tempo and phase."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    t = np.arange(n) / FPS + rng.uniform(0, period)
    rot = np.zeros((n, len(SKEL), 3))
    swing = 0.6 * (1 - np.cos(np.pi * t / period)) / 2
    rot[:, J["L_Shoulder"], 2] = swing * rng.uniform(0.5, 1.0)
    rot[:, J["R_Shoulder"], 2] = -swing * rng.uniform(0.5, 1.0)
    rot[:, J["L_Elbow"], 1] = 0.8 * swing
    rot[:, J["L_Knee"], 0] = 0.4 * swing
    root = np.tile(SKEL.offsets[0], (n, 1))
    root[:, 2] += travel * np.arange(n) / FPS
    return Motion(SKEL, FPS, root, expmap_to_quat(rot))


@pytest.fixture(scope="module")
def graph():
    return MotionGraph([take(20, 0.55, 0), take(20, 0.7, 1), take(20, 0.6, 2)], ["a", "b", "c"])


def test_segments_run_from_accent_to_accent_and_transitions_join_near_poses(graph):
    assert len(graph.segments) > 50
    lengths = np.array([s.frames for s in graph.segments]) / FPS
    assert lengths.min() >= graph.options.min_seconds - 1e-9 and lengths.max() <= graph.options.max_seconds + 1e-9
    assert 0.4 < np.median(lengths) < 0.8  # the takes' accents, 0.55-0.7 s apart
    assert graph.transitions.shape == (len(graph.segments), graph.options.neighbours)
    assert np.all(np.diff(graph.cost, axis=1) >= 0)  # nearest first


def test_a_dance_is_warped_onto_the_songs_beats_deterministically(graph):
    beats = np.arange(0.25, 20.0, 0.5)  # 120 BPM, no take's tempo
    dance = graph.dance(beats, 20.0, FPS, np.random.default_rng(3))
    assert dance.n_frames == 600 and dance.fps == FPS and dance.skeleton.same_topology(SKEL)
    again = graph.dance(beats, 20.0, FPS, np.random.default_rng(3))
    np.testing.assert_array_equal(dance.rotations, again.rotations)
    other = graph.dance(beats, 20.0, FPS, np.random.default_rng(4))
    assert np.abs(other.rotations - dance.rotations).max() > 0.1
    locked = body_locking(dance.positions(), FPS, SKEL.names, beats)
    assert locked["locking"] > 0.5 and locked["locking"] > 3 * abs(locked["control"])
    # continuous: no joint jumps between frames (transitions blend, positions carry over)
    speed = np.linalg.norm(np.diff(dance.positions(), axis=0), axis=-1).max(1) * FPS
    assert speed.max() < 6.0
    assert np.ptp(dance.root[:, 2]) > 1.0  # it travels on from where each segment ended


def test_grounded_and_bad_input():
    standing = MotionGraph([take(20, 0.55, 0, travel=0.0), take(20, 0.7, 1, travel=0.0)])
    dance = real_dance(standing, np.arange(0.3, 10.0, 0.6), 10.0, FPS, np.random.default_rng(0))
    low = dance.positions(end_sites=True)[..., 1].min(axis=1)
    assert abs(np.median(low)) < 0.02
    with pytest.raises(DataError, match="at least 2 beats"):
        standing.dance(np.array([1.0]), 5.0, FPS, np.random.default_rng(0))
    with pytest.raises(DataError, match="no takes"):
        MotionGraph([])
    with pytest.raises(DataError, match="one skeleton at one frame rate"):
        MotionGraph([take(5, 0.5, 0), take(5, 0.5, 1).resample(20.0)])


def test_homogeneous_real_moves_give_one_song_one_dance(graph):
    from dance_core.synth.synthetic_dance import REAL, make_clip

    kw = {"seed": 0, "seconds": 8.0, "bpm": (100.0, 120.0), "rate": 8000, "fps": FPS, "dances_per_song": 3,
          "graph": graph}

    def positions(index, homogeneous):
        clip = make_clip(index, homogeneous=homogeneous, **kw)
        assert clip.meta["dancer"] == REAL and clip.texts == ()
        return clip.motion.skeleton_motion.positions()

    # song 1, dances 0 and 2: the control's are the same dance (one routine), the multimodal set's are not
    np.testing.assert_array_equal(positions(3, True), positions(5, True))
    assert np.abs(positions(3, False) - positions(5, False)).max() > 0.05  # metres
    # the routine is walked to each song's own beats: another song, another dance
    assert np.abs(positions(0, True) - positions(3, True)).max() > 0.05


@pytest.mark.skipif(not MOCAP.is_dir(), reason="../shared/mocap not available")
def test_real_takes_make_a_dance_with_the_statistics_of_real_dance(tmp_path):
    from dance_core.data.dataset_configs import MocapDatasetConfig
    from dance_core.data.mocap import MocapDataset
    from dance_core.evaluation.realism import STATISTICS, window_statistics

    cfg = MocapDatasetConfig(path=str(MOCAP), files=["salsa_60_0[1-3].bvh", "modern_05_0[2-4].bvh"],
                             cache=str(tmp_path / "cache"))
    clips = MocapDataset(cfg, FPS).clips()
    real = MotionGraph([c.motion.skeleton_motion for c in clips], [c.name for c in clips])
    beats = np.arange(0.4, 20.0, 0.5)
    dance = real_dance(real, beats, 20.0, FPS, np.random.default_rng(1))
    stats = dict(zip(STATISTICS, np.median(window_statistics(dance.positions(), FPS, SKEL.names), axis=0),
                     strict=True))
    assert stats["elbow_bend"] > 50 and stats["knee_bend"] > 30  # bent like people, not straight
    assert stats["weight_changes"] > 0.3 and stats["root_travel"] > 0.1  # it steps and travels
    # its body locks to the beats, well above the control (the beats moved off the music), over three walks
    # of the graph (one walk's control swings from -0.4 to 0.25 with the path taken)
    locked = [body_locking(d.positions(), FPS, SKEL.names, beats) for d in
              [dance] + [real_dance(real, beats, 20.0, FPS, np.random.default_rng(seed)) for seed in (2, 3)]]
    assert all(lock["locking"] > lock["control"] for lock in locked)
    assert np.mean([lock["locking"] for lock in locked]) > 2 * np.mean([abs(lock["control"]) for lock in locked])
