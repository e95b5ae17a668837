"""The synthetic choreography's dancers: several per song, Markov phrasing, the homogeneous control, and
the default that still gives the dances of before the dancers existed."""

import hashlib

import numpy as np
import pytest

from dance_core.synth.dancer import CLASSIC, DANCERS, MOVES, NAMES
from dance_core.synth.synthetic_dance import make_clip

KW = {"seconds": 10.0, "bpm": (80.0, 140.0), "rate": 8000, "fps": 30.0}
MOVE_OF = {text: name for name, text in MOVES.items()}


def digest(clip) -> str:
    """A short hash of a clip's joint positions (rounded to 0.1 mm) and its text labels."""
    h = hashlib.sha256()
    h.update(np.round(clip.motion.values.astype(np.float64), 4).tobytes())
    h.update(repr([(t.text, t.start, t.end) for t in clip.texts]).encode())
    return h.hexdigest()[:16]


def test_the_default_gives_the_dances_of_before_the_dancers_bit_for_bit():
    # hashes of the generator before dancer profiles existed (commit e5d34fb): a 3/4 and a 4/4 dance
    # of two dances per song, one dance per song, and a synthetic-moves clip (same pose functions);
    # rehashed on the dance24 skeleton, standing at its rest height (its rest soles are on the floor, so
    # no 3 cm foot thickness is added; root height and knee bends follow the body); with SMPL's template
    # rest pose and the old standing height put back it gives e5d34fb's 0a7e195323e783b4, 4c284bb5ca3b2124...
    from dance_core.synth.synthetic_moves import make_move_clip

    assert digest(make_clip(0, seed=3, dances_per_song=2, **KW)) == "090b1d749108b4e5"
    assert digest(make_clip(3, seed=3, dances_per_song=2, **KW)) == "3084a0cd0beb81c7"
    assert digest(make_clip(1, seed=3, **KW)) == "5f7424a4b444f7ab"
    moves = make_move_clip(0, seed=2, seconds=(2.0, 6.0), bpm=(80.0, 140.0), rate=8000, fps=30.0)
    assert digest(moves) == "9ea936f0c69a729f"


@pytest.fixture(scope="module")
def song():
    """The six dances of one 4/4 song, one per dancer."""
    return [make_clip(i, seed=1, dances_per_song=6, dancers=None, **{**KW, "seconds": 16.0}) for i in range(6, 12)]


def test_every_dance_of_a_song_has_its_own_dancer_and_the_same_music(song):
    assert sorted(c.meta["dancer"] for c in song) == sorted(DANCERS)
    assert len(DANCERS) >= 5 and all(c.meta["beats_per_bar"] == 4 for c in song)
    for clip in song[1:]:
        np.testing.assert_array_equal(clip.audio.samples, song[0].audio.samples)
        assert np.abs(clip.motion.values - song[0].motion.values).max() > 0.1
    again = make_clip(7, seed=1, dances_per_song=6, dancers=None, **{**KW, "seconds": 16.0})
    np.testing.assert_array_equal(again.motion.values, song[1].motion.values)


def test_each_dancer_dances_its_own_moves_along_its_chain(song):
    for clip in song:
        dancer = DANCERS[clip.meta["dancer"]]
        moves = [MOVE_OF[t.text] for t in clip.texts]
        assert set(moves) <= set(dancer.moves)
        if dancer.chain is not None:  # consecutive labels differ, so each is a successor of the one before
            assert all(b in dancer.chain[a] for a, b in zip(moves[:-1], moves[1:], strict=True))
    for name, dancer in DANCERS.items():
        if dancer.chain is not None:  # real branching: every move has at least three successors
            assert all(len(nxt) >= 3 for nxt in dancer.chain.values()), name
            assert set(dancer.chain) == {m for nxt in dancer.chain.values() for m in nxt}, name


def test_phrases_change_at_beats_between_the_bar_lines(song):
    off_bar = 0
    for clip in song:
        if clip.meta["dancer"] == CLASSIC:
            continue
        beats, first = np.asarray(clip.meta["beats"]), clip.meta["first_downbeat"]
        for span in clip.texts[1:]:
            i = int(np.argmin(np.abs(beats - span.start)))
            assert abs(beats[i] - span.start) < 1e-3  # every change on a beat...
            off_bar += (i - first) % 4 != 0  # ...and many of them inside a bar
    assert off_bar >= 5


def test_the_dancers_time_their_accents_on_or_off_the_beat(song):
    for clip in song:
        dancer = DANCERS[clip.meta["dancer"]]
        y = clip.motion.skeleton_motion.positions()[:, 0, 1]
        v = np.diff(y)
        bottoms = (np.flatnonzero((v[:-1] < 0) & (v[1:] >= 0)) + 1) / KW["fps"]
        beats = np.asarray(clip.meta["beats"])
        period = np.median(np.diff(beats))
        inside = bottoms[(bottoms > beats[0] + period) & (bottoms < beats[-1] - period)]
        phase = np.interp(inside, beats, np.arange(len(beats))) % 1.0  # where in its beat each bottom falls
        off = np.abs(((phase - dancer.delay) + 0.5) % 1.0 - 0.5)
        assert np.median(off) < 0.08, (clip.meta["dancer"], np.median(off))


def test_the_dancers_stay_on_their_feet_and_move_smoothly(song):
    for clip in song:
        pos = clip.motion.skeleton_motion.positions()
        feet = pos[:, [10, 11], 1].min(axis=1)
        assert feet.min() > -0.05 and np.median(feet) < 0.1
        assert np.linalg.norm(np.diff(pos, axis=0), axis=-1).max() * KW["fps"] < 12.0


def test_the_homogeneous_control_is_one_dancer_one_style_one_routine():
    a, b = (make_clip(i, seed=1, dances_per_song=2, homogeneous=True, dancers=["bouncer"], **KW) for i in (0, 1))
    np.testing.assert_array_equal(a.motion.values, b.motion.values)
    assert a.meta["dancer"] == b.meta["dancer"] == "bouncer" and a.texts == b.texts
    moves = [MOVE_OF[t.text] for t in a.texts]
    assert set(moves) <= set(DANCERS["bouncer"].moves) and len(set(moves)) >= 2
    other = make_clip(2, seed=1, dances_per_song=2, homogeneous=True, dancers=["bouncer"], **KW)  # another song
    assert other.meta["bpm"] != a.meta["bpm"]
    classic = make_clip(0, seed=1, homogeneous=True, **KW)  # the default dancer, in its central style
    assert classic.meta["dancer"] == CLASSIC and {MOVE_OF[t.text] for t in classic.texts} <= set(NAMES)


def test_config_options_and_the_dataset(tmp_path):
    from pydantic import ValidationError

    from dance_core.synth.configs import SyntheticDanceConfig
    from dance_core.synth.synthetic_dance import build

    assert SyntheticDanceConfig().dancers == [CLASSIC] and not SyntheticDanceConfig().homogeneous
    assert SyntheticDanceConfig(dancers=None).dancers is None
    with pytest.raises(ValidationError, match="unknown dancer"):
        SyntheticDanceConfig(dancers=["nobody"])
    config = SyntheticDanceConfig(songs=1, seconds=4.0, dances_per_song=2, dancers=["glider", "hitter"],
                                  sample_rate=8000, motion_fps=20.0)
    clips = build(config, fps=30.0).clips()
    assert [c.name for c in clips] == ["synth-0000-0", "synth-0000-1"]
    assert sorted(c.meta["dancer"] for c in clips) == ["glider", "hitter"]


def test_dance_synth_writes_several_dancers_and_the_control(tmp_path, capsys):
    from dance_core.cli.main import main

    out = tmp_path / "d"
    assert main(["synth", "--out", str(out), "--songs", "1", "--dances", "2", "--dancers", "bouncer", "glider",
                 "--seconds", "3",
                 "--fps", "20", "--rate", "8000", "--seed", "2"]) == 0
    heads = [(out / f"synth-0000-{k}.sections").read_text().splitlines()[0] for k in (0, 1)]
    assert all(" dancer " in h for h in heads) and heads[0].split()[-1] != heads[1].split()[-1]
    assert main(["synth", "--out", str(tmp_path / "c"), "--songs", "1", "--seconds", "3", "--fps", "20",
                 "--rate", "8000", "--homogeneous", "--dancers", "all"]) == 0  # all: the classic one first
    assert " dancer " not in (tmp_path / "c" / "synth-0000.sections").read_text().splitlines()[0]
    assert main(["synth", "--out", str(tmp_path / "e"), "--dancers", "nobody", "--seconds", "3"]) == 1
    assert "unknown dancer" in capsys.readouterr().err
