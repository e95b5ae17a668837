"""The bundled DanceRevolution (``dancerevolution-real``): it loads, matches its recipe, and composes
different dances on the beat on CPU."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dance_core.checkpoint import check_matches, load_checkpoint
from dance_core.compose import compose
from dance_core.data.files import read_motion_file as read_motion
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry

BUNDLED = Path(__file__).resolve().parents[1] / "src" / "dance_rnn" / "bundled" / "dancerevolution-real.safetensors"
FIXTURES = Path(__file__).resolve().parents[3].parent / "shared" / "fixtures" / "audio"


def synthesized(path: Path, seconds: float, bpm: float, seed: int) -> Path:
    """A synthesized song written as WAV."""
    from dance_core.formats.wav import write_wav
    from dance_core.synth.music import synthesize

    write_wav(path, synthesize(seconds, bpm, 22050, np.random.default_rng(seed)).audio, 22050)
    return path


def test_the_bundled_weights_are_small_and_match_their_recipe():
    assert BUNDLED.stat().st_size <= 5 * 2**20
    recipe = load_recipe("dancerevolution-real")
    assert Path(recipe.resolve_path(recipe.compose.checkpoint)).resolve() == BUNDLED.resolve()
    ckpt = load_checkpoint(BUNDLED)
    assert recipe.model_dict(ckpt.recipe)["model"] == recipe.model_dict()["model"]
    check_matches(ckpt, recipe)
    assert ckpt.step == recipe.training.steps


def test_the_bundled_model_composes_different_samples_that_keep_moving(tmp_path):
    song = synthesized(tmp_path / "song.wav", 12.0, 110.0, 11)
    recipe = load_recipe("dancerevolution-real", ["compose.samples=2", "compose.formats=[bvh]"])
    written = compose(recipe, music=[str(song)], out_dir=str(tmp_path / "out"), quiet=True)
    assert sorted(p.name for p in written) == ["song-0.bvh", "song-1.bvh"]
    registry = get_registry()
    a, b = (read_motion(tmp_path / "out" / f"song-{k}.bvh", registry) for k in (0, 1))
    assert a.values.shape[0] == 240 and a.fps == 20  # the whole song at 20 fps
    assert np.all(np.isfinite(a.values)) and np.all(np.isfinite(b.values))
    # samples differ only through the LSTM's random initial state; they must still be different dances
    assert np.abs(a.values[40:] - b.values[40:]).mean() > 5.0  # degrees / cm (about 17 here), not rounding
    for m in (a, b):  # limbs still move in the last 4 s as in the first 4 s after the seed (no freezing)
        p = m.skeleton_motion.positions()
        v = np.linalg.norm(np.diff(p - p[:, :1], axis=0), axis=-1).mean(1) * 20.0
        assert v[160:].mean() > 0.5 * v[20:100].mean() > 0.05


def test_the_same_song_and_seed_give_the_same_dance(tmp_path):
    song = synthesized(tmp_path / "song.wav", 3.0, 120.0, 2)
    recipe = load_recipe("dancerevolution-real", ["compose.formats=[bvh]"])
    for run in ("a", "b"):
        compose(recipe, music=[str(song)], out_dir=str(tmp_path / run), quiet=True)
    assert (tmp_path / "a" / "song.bvh").read_bytes() == (tmp_path / "b" / "song.bvh").read_bytes()


def test_the_bundled_model_dances_to_a_real_song(tmp_path):
    song = FIXTURES / "vibe_ace.ogg"
    if not song.exists():
        pytest.skip(f"fixture {song} not available")
    recipe = load_recipe("dancerevolution-real", ["compose.seconds=4"])
    written = compose(recipe, music=[str(song)], out_dir=str(tmp_path), quiet=True)
    assert {p.suffix for p in written} == {".bvh", ".html"}
    motion = read_motion(tmp_path / "vibe_ace.bvh", get_registry())
    assert motion.values.shape[0] == 80 and motion.fps == 20 and np.all(np.isfinite(motion.values))


def test_the_bundled_dancer_puts_its_accents_on_the_beat(tmp_path):
    """``compose.beat_align`` (on in the recipe): body locking well above the wrong-tempo control."""
    from dance_core.compose.composer import Composer
    from dance_core.evaluation.realism import body_locking

    synthesized(tmp_path / "song.wav", 20.0, 112.0, 5)
    composer = Composer(load_recipe("dancerevolution-real", ["compose.samples=3"]))
    loaded = composer.song(tmp_path / "song.wav")
    dances = composer.dances(loaded, composer.generate(loaded))
    scores = [body_locking(d.skeleton_motion.positions(), 20.0, d.skeleton_motion.skeleton.names, loaded.beats)
              for d in dances]
    on, off = (np.mean([s[key] for s in scores]) for key in ("locking", "control"))
    assert on > 3 * max(off, 0.05)
