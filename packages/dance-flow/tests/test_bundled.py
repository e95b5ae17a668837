"""The bundled model: it loads, matches its recipe, and composes dances on CPU."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dance_core.checkpoint import check_matches, load_checkpoint
from dance_core.compose import compose
from dance_core.data.files import read_motion_file as read_motion
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry

BUNDLED = Path(__file__).resolve().parents[1] / "src" / "dance_flow" / "bundled" / "transflower-small.safetensors"
FIXTURES = Path(__file__).resolve().parents[3].parent / "shared" / "fixtures" / "audio"


def test_the_bundled_weights_are_small_and_match_the_default_recipe():
    assert BUNDLED.stat().st_size <= 20 * 2**20
    recipe = load_recipe("default")
    assert recipe.name == "transflower-small"
    assert Path(recipe.resolve_path(recipe.compose.checkpoint)).resolve() == BUNDLED.resolve()
    ckpt = load_checkpoint(BUNDLED)
    assert recipe.model_dict(ckpt.recipe)["model"] == recipe.model_dict()["model"]
    check_matches(ckpt, recipe)
    assert ckpt.step == recipe.training.steps


def test_the_bundled_model_composes_several_songs_and_samples(tmp_path):
    from dance_core.formats.wav import write_wav
    from dance_core.synth.music import synthesize

    songs = []
    for seconds, name in ((3.0, "short"), (4.5, "long")):
        rng = np.random.default_rng(11)
        song = synthesize(seconds, 110.0, 22050, rng)
        songs.append(tmp_path / f"{name}.wav")
        write_wav(songs[-1], song.audio, 22050)
    recipe = load_recipe("default", ["compose.samples=2", "compose.formats=[bvh, npz]"])
    written = compose(recipe, music=[str(s) for s in songs], out_dir=str(tmp_path / "out"), quiet=True)
    bvhs = sorted(p for p in written if p.suffix == ".bvh")
    assert [p.name for p in bvhs] == ["long-0.bvh", "long-1.bvh", "short-0.bvh", "short-1.bvh"]
    registry = get_registry()
    lengths = {p.name: read_motion(p, registry).values.shape[0] for p in bvhs}
    assert lengths["short-0.bvh"] == 60 and lengths["long-0.bvh"] == 90  # whole songs at 20 fps
    a, b = (read_motion(tmp_path / "out" / f"long-{k}.bvh", registry).values for k in (0, 1))
    assert np.all(np.isfinite(a)) and not np.allclose(a[40:], b[40:])  # two different samples
    assert a[40:].std(0).max() > 1e-3  # it moves after the rest-pose seed


def test_the_bundled_model_dances_to_a_real_song(tmp_path):
    song = FIXTURES / "vibe_ace.ogg"
    if not song.exists():
        pytest.skip(f"fixture {song} not available")
    recipe = load_recipe("default", ["compose.seconds=4"])
    written = compose(recipe, music=[str(song)], out_dir=str(tmp_path), quiet=True)
    assert {p.suffix for p in written} == {".bvh", ".html"}
    motion = read_motion(tmp_path / "vibe_ace.bvh", get_registry())
    assert motion.values.shape[0] == 80 and motion.fps == 20 and np.all(np.isfinite(motion.values))


def test_built_in_seeds_prompt_the_dance(tmp_path, demo_wav):
    outs = {}
    for seed in ("rest", "seeds/claps.bvh", "seeds/walks.bvh"):
        recipe = load_recipe(
            "default", [f"compose.seed_motion={seed}", "compose.formats=[npz]", "compose.temperature=0"]
        )
        (path,) = compose(recipe, music=[str(demo_wav)], out_dir=str(tmp_path / seed.replace("/", "-")), quiet=True)
        data = np.load(path)
        outs[seed] = data[[k for k in data.files if data[k].ndim == 2][0]]
    rest, claps, walks = outs["rest"], outs["seeds/claps.bvh"], outs["seeds/walks.bvh"]
    assert not np.allclose(rest[:40], claps[:40]) and not np.allclose(claps[:40], walks[:40])
    assert not np.allclose(claps[40:], walks[40:])  # the prompt changes what follows


@pytest.fixture
def demo_wav(tmp_path):
    """A 3-second synthesized song."""
    from dance_core.formats.wav import write_wav
    from dance_core.synth.music import synthesize

    song = synthesize(3.0, 120.0, 22050, np.random.default_rng(3))
    path = tmp_path / "demo.wav"
    write_wav(path, song.audio, 22050)
    return path


def test_the_same_song_and_seed_give_the_same_files_byte_for_byte(tmp_path):
    """Dance and preview: the HTML player is titled with the file's own name, not the temporary one it
    is written under, so two runs write the same bytes."""
    from dance_core.formats.wav import write_wav
    from dance_core.synth.music import synthesize

    song = tmp_path / "song.wav"
    write_wav(song, synthesize(3.0, 120.0, 22050, np.random.default_rng(2)).audio, 22050)
    recipe = load_recipe("default", ["compose.formats=[bvh, html]"])
    for run in ("a", "b"):
        compose(recipe, music=[str(song)], out_dir=str(tmp_path / run), quiet=True)
    for name in ("song.bvh", "song.html"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    assert "<title>song</title>" in (tmp_path / "a" / "song.html").read_text(encoding="utf-8")


def test_the_bundled_dancer_puts_its_own_accents_on_the_beat(tmp_path):
    """``compose.beat_align`` (on in the bundled recipe) moves the body's accents onto the tracked beats:
    body locking rises well above the same dances unaligned and above the wrong-tempo control."""
    from dataclasses import replace

    from dance_core.compose.composer import Composer
    from dance_core.evaluation.realism import body_locking
    from dance_core.formats.wav import write_wav
    from dance_core.synth.music import synthesize

    song = synthesize(20.0, 112.0, 22050, np.random.default_rng(5))
    write_wav(tmp_path / "song.wav", song.audio, 22050)
    composer = Composer(load_recipe("default", ["compose.samples=3"]))
    loaded = composer.song(tmp_path / "song.wav")
    assert loaded.beats is not None and abs(np.median(np.diff(loaded.beats)) - 60 / 112) < 0.02
    motion = composer.generate(loaded)
    aligned = composer.dances(loaded, motion)
    plain = composer.dances(replace(loaded, beats=None), motion)  # the same dances, not aligned
    score = lambda d: body_locking(d.skeleton_motion.positions(), 20.0, d.skeleton_motion.skeleton.names,  # noqa: E731
                                   loaded.beats)
    on, off = [np.mean([score(d)[key] for d in aligned]) for key in ("locking", "control")]
    before = np.mean([score(d)["locking"] for d in plain])
    assert all("beat_align" in d.meta and d.meta["beat_align"]["max_rate"] <= 1.35 + 1e-6 for d in aligned)
    assert on > before + 0.15 and on > 3 * max(off, 0.05)


def test_the_bundled_dancer_dances_from_the_first_frame(tmp_path):
    """``compose.lead_in`` (on in the bundled recipe): the rest-pose seed and a pre-roll of the song's
    opening are danced before the song starts and dropped, so the limbs move in the first second as
    they do later; without it the dance rises from the seed over its first two seconds."""
    from dance_core.compose.composer import Composer
    from dance_core.formats.wav import write_wav
    from dance_core.synth.music import synthesize

    song = synthesize(12.0, 118.0, 22050, np.random.default_rng(9))
    write_wav(tmp_path / "song.wav", song.audio, 22050)

    def limb_speed(lead_in):
        composer = Composer(load_recipe("default", ["compose.samples=2", f"compose.lead_in={lead_in}"]))
        loaded = composer.song(tmp_path / "song.wav")
        dances = composer.dances(loaded, composer.generate(loaded))
        speeds = []
        for d in dances:
            p = d.skeleton_motion.positions()
            assert len(p) == loaded.n_frames
            v = np.linalg.norm(np.diff(p - p[:, :1], axis=0), axis=-1).mean(1) * 20.0
            speeds.append((v[:20].mean(), v[60:].mean()))
        return np.mean(speeds, axis=0)

    first, later = limb_speed("true")
    assert first > 0.5 * later
    first_plain, later_plain = limb_speed("false")
    assert first_plain < 0.25 * later_plain  # the seed's still pose and the rise from it
