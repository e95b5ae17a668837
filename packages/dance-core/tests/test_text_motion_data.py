"""TM2D's two corpora from the synthetic dancer: text-motion clips (``synthetic-moves``), and ``mix``."""

import numpy as np
import pytest

from dance_core.contexts import DatasetContext
from dance_core.errors import PluginError, RecipeError
from dance_core.registry import get_registry
from dance_core.synth.dancer import MOVES, PHRASINGS, STAND, all_texts
from dance_core.synth.synthetic_moves import make_move_clip

PELVIS, L_HIP, R_HIP, L_ANKLE, R_ANKLE, HEAD, L_WRIST, R_WRIST, L_HAND, R_HAND = 0, 1, 2, 7, 8, 15, 20, 21, 22, 23
KW = {"seconds": (2.0, 10.0), "bpm": (80.0, 140.0), "rate": 8000, "fps": 30.0}


def moves_dataset(fps=30.0, **options):
    return get_registry().create("dataset", "synthetic-moves", options, DatasetContext(fps=fps))


@pytest.fixture(scope="module")
def clips():
    return moves_dataset(clips=2 * len(MOVES), seed=3).clips()


def test_every_move_has_several_distinct_phrasings():
    assert list(PHRASINGS) == list(MOVES)
    for move, phrasings in PHRASINGS.items():
        assert len(phrasings) >= 4 and len(set(phrasings)) == len(phrasings)
        assert phrasings[0] == MOVES[move]  # the dance's label is one of them
    texts = all_texts()
    assert len(texts) == sum(len(p) for p in PHRASINGS.values())  # no wording shared by two moves
    assert set(MOVES.values()) <= set(texts)


def test_all_texts_make_a_vocabulary_without_unknown_words(tmp_path):
    text = pytest.importorskip("dance_audio.text")
    text.Vocabulary.build(all_texts()).save(tmp_path / "vocab.txt")
    vocab = text.Vocabulary.load(tmp_path / "vocab.txt")
    for sentence in all_texts():
        assert vocab.ids[text.UNK] not in vocab.encode(sentence, 32)


def _facing(p):
    """Unit forward direction on the ground (x, z) from the hips: left hip minus right hip, turned."""
    d = p[:, L_HIP] - p[:, R_HIP]
    f = np.stack([-d[:, 2], d[:, 0]], -1)
    return f / np.linalg.norm(f, axis=-1, keepdims=True)


def _forward_of_pelvis(p, joints):
    """How far each joint is in front of the pelvis, along the facing, per frame."""
    rel = (p[:, joints] - p[:, None, PELVIS])[..., [0, 2]]
    return (rel * _facing(p)[:, None]).sum(-1)


DETECTORS = {  # on joint positions only, each true of its own move and of no other
    "jump": lambda p: p[:, PELVIS, 1].max() > STAND + 0.05,  # the pelvis rises well above standing
    "walk": lambda p: (np.diff(p[:, PELVIS, [0, 2]], axis=0) * _facing(p)[:-1]).sum() > 0.3,  # travels forward
    "spin": lambda p: np.abs(np.diff(np.unwrap(np.arctan2(*_facing(p).T)))).sum() > 2 * np.pi
    and np.linalg.norm(p[:, PELVIS, [0, 2]] - p[0, PELVIS, [0, 2]], axis=-1).max() < 0.1,  # turns, stays put
    "kick": lambda p: _forward_of_pelvis(p, [L_ANKLE, R_ANKLE]).max() > 0.3,  # a foot swings out in front
    "clap": lambda p: _forward_of_pelvis(p, [L_HAND, R_HAND]).min(1).max() > 0.3  # both hands out in front...
    and np.ptp(np.linalg.norm(p[:, L_HAND] - p[:, R_HAND], axis=-1)) > 0.3,  # ...closing and opening
    "arm-wave": lambda p: (p[:, [L_WRIST, R_WRIST], 1].min(1) - p[:, HEAD, 1]).max() > 0.2,  # both arms overhead
}


def test_a_moves_clip_is_one_move_described_by_its_text(clips):
    assert sorted(c.meta["move"] for c in clips) == sorted(list(MOVES) * 2)  # dealt in turn
    for clip in clips:
        move = clip.meta["move"]
        seconds = clip.audio.duration
        assert 2.0 <= seconds <= 10.0
        (span,) = clip.texts
        assert span.text in PHRASINGS[move] and span.start == 0.0 and span.end == pytest.approx(seconds, abs=1e-3)
        p = clip.motion.skeleton_motion.positions()
        fired = {name for name, detect in DETECTORS.items() if detect(p)}
        assert fired == ({move} & set(DETECTORS)), (clip.name, fired)
    assert len({c.texts[0].text for c in clips}) > len(MOVES)  # several wordings in use


def test_moves_clips_have_silent_music_as_long_as_their_motion(clips):
    for clip in clips:
        assert clip.audio is not None and not np.any(clip.audio.samples)
        assert clip.audio.n_frames(clip.motion.fps) == len(clip.motion.values)


def test_clips_may_start_and_end_in_the_rest_pose():
    rested = make_move_clip(6, seed=0, rest=1.0, **KW)  # a jump
    start, end = rested.meta["rest"]
    assert start > 0 and end > 0
    p = rested.motion.skeleton_motion.positions()
    hold = int(0.4 * min(start, end) * rested.motion.fps)
    assert hold >= 3
    for still in (p[:hold], p[-hold:]):  # standing still, upright, at standing height
        np.testing.assert_allclose(still, still[:1].repeat(len(still), 0), atol=1e-6)
        assert still[0, PELVIS, 1] == pytest.approx(STAND)
    moving = make_move_clip(6, seed=0, rest=0.0, **KW).motion.skeleton_motion.positions()
    assert np.abs(np.diff(moving[:hold], axis=0)).max() > 1e-3


def test_deterministic_from_the_seed():
    a, b = moves_dataset(clips=4, seed=5).clips(), moves_dataset(clips=4, seed=5).clips()
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.motion.values, y.motion.values)
        assert x.texts == y.texts and x.name == y.name and len(x.audio.samples) == len(y.audio.samples)
    c = moves_dataset(clips=4, seed=6).clips()
    assert any(x.texts != z.texts or x.motion.values.shape != z.motion.values.shape for x, z in zip(a, c, strict=True))


def test_a_moves_subset_and_option_errors():
    assert {c.meta["move"] for c in moves_dataset(clips=3, moves=["jump", "clap"]).clips()} == {"jump", "clap"}
    for bad, field in (({"moves": ["moonwalk"]}, "moves"), ({"seconds": [4, 2]}, "seconds"),
                       ({"seconds": [0.2, 2]}, "seconds"), ({"bpm": [140, 80]}, "bpm"), ({"rest": 2}, "rest")):
        with pytest.raises(PluginError, match=f"synthetic-moves.*{field}"):
            moves_dataset(**bad)


def test_a_moves_clip_writes_like_a_synthetic_dance(tmp_path):
    from dance_core.synth.synthetic_dance import write_clip

    clip = make_move_clip(0, seed=1, **{**KW, "seconds": (2.0, 2.5)})
    write_clip(tmp_path, clip)
    assert (tmp_path / f"{clip.name}.texts").read_text().split("\t")[2].strip() == clip.texts[0].text
    assert (tmp_path / f"{clip.name}.bvh").exists() and (tmp_path / f"{clip.name}.wav").exists()


def mix(*parts, fps=20.0):
    return get_registry().create("dataset", "mix", {"datasets": list(parts)}, DatasetContext(fps=fps))


def test_mix_keeps_names_unique_and_can_drop_a_parts_texts():
    dance = {"plugin": "synthetic-dance", "songs": 2, "seconds": 4, "sample_rate": 8000}
    moves = {"plugin": "synthetic-moves", "clips": 2, "seconds": [2, 3], "sample_rate": 8000}
    kept = mix(dance, moves, moves).clips()
    names = [c.name for c in kept]
    assert names == ["0-synth-0000", "0-synth-0001", "1-move-0000-bounce", "1-move-0001-step-touch",
                     "2-move-0000-bounce", "2-move-0001-step-touch"]
    assert all(c.texts for c in kept)  # synthetic-dance labels its moves
    assert [c.meta["dataset"] for c in kept[:3]] == ["synthetic-dance", "synthetic-dance", "synthetic-moves"]
    dropped = mix({**dance, "keep_texts": False}, moves).clips()
    assert [bool(c.texts) for c in dropped] == [False, False, True, True]
    np.testing.assert_array_equal(dropped[0].motion.values, kept[0].motion.values)


def test_mix_option_errors_name_the_part_and_field(tmp_path):
    from dance_core.recipe import load_recipe

    with pytest.raises(PluginError, match=r"datasets\.1\.clips"):
        mix({"plugin": "synthetic-dance"}, {"plugin": "synthetic-moves", "clips": -1})
    recipe = tmp_path / "bad.yaml"
    recipe.write_text("extends: core-dance\ndata:\n  dataset:\n    plugin: mix\n    datasets:\n"
                      "      - {plugin: synthetic-dance, songs: 2, colour: red}\n"
                      "      - {plugin: synthetic-moves, seconds: [4, 2]}\n"
                      "      - {plugin: no-such-dataset}\n")
    with pytest.raises(RecipeError) as err:
        load_recipe(recipe)
    lines = str(err.value).splitlines()
    assert len(lines) == 3
    assert "bad.yaml:6: data.dataset.datasets.0.colour: " in lines[0]
    assert "bad.yaml:7: data.dataset.datasets.1.seconds: " in lines[1] and "backwards" in lines[1]
    assert "bad.yaml:8: data.dataset.datasets.2.plugin: unknown dataset 'no-such-dataset'" in lines[2]


def test_a_mix_recipe_trains_with_text_only_on_the_moves_clips(tmp_path):
    text = pytest.importorskip("dance_audio.text")
    from dance_core.data.features import FeatureStack
    from dance_core.data.prepare import dataset_sources, to_clip
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    text.Vocabulary.build(all_texts()).save(tmp_path / "vocab.txt")
    recipe = tmp_path / "tm2d-data.yaml"
    recipe.write_text(f"""extends: core-dance
features:
  music: [{{plugin: energy}}]
  text: [{{plugin: word-tokens, vocab: {tmp_path / 'vocab.txt'}, max_words: 12}}]
data:
  dataset:
    plugin: mix
    datasets:
      - {{plugin: synthetic-dance, songs: 2, seconds: 6, sample_rate: 8000, keep_texts: false}}
      - {{plugin: synthetic-moves, clips: 9, seconds: [2, 3], sample_rate: 8000}}
  mirror: false
training: {{steps: 4, batch_size: 4, val_every: 4, checkpoint_every: 4}}
""")
    loaded = load_recipe(recipe)
    stack = FeatureStack(loaded)
    prepared = [to_clip(s, stack, get_registry()) for s in dataset_sources(loaded)]
    assert len(prepared) == 11
    for clip in prepared:
        is_move = clip.name.startswith("1-move-")
        tokens, music = clip.streams["text"], clip.streams["music"]
        assert tokens.shape == (len(clip), 12) and music.shape == (len(clip), 4)
        assert bool(tokens.any(axis=1).all()) == is_move and bool(tokens.any()) == is_move  # every frame, or none
        assert (music.std(axis=0).max() < 1e-3) == is_move  # silence: constant music features
    result = train(loaded, out=str(tmp_path / "run"), quiet=True)
    assert np.isfinite(result.last_loss) and result.checkpoint.exists()
