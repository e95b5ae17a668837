"""Issue 15, batched generation: ``compose.batch_songs`` puts several songs in one batch, each song's
music edge-padded to the longest and its rows drawing from its own random stream (``RowGenerators``),
so each song's dance equals its per-song dance within float rounding; per-song mode is unchanged."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from dance_core import RowGenerators, Window, draw_rows, hookimpl
from dance_core.components.configs import RegressionHeadConfig
from dance_core.components.modules import RegressionHead
from dance_core.compose import batching_note, compose_songs, generate_song, generate_songs, load_model, load_song
from dance_core.recipe import load_recipe
from dance_core.registry import get_registry
from dance_core.row_generators import supports_row_generators
from dance_core.shards import Shard
from dance_core.testing import registered_plugin
from dance_core.train import train

sys.path.insert(0, str(Path(__file__).parent))
from compose_helpers import click_song  # noqa: E402

TINY = ["data.dataset.songs=4", "data.dataset.seconds=6", "training.steps=10", "training.batch_size=16",
        "training.val_every=10", "training.checkpoint_every=10", "training.log_every=10",
        "model.head.plugin=row-noisy-head"]
#: batched songs equal per-song generation within this (float rounding through a few dozen steps)
TOLERANCE = 1e-4


class RowNoisyHead(RegressionHead):
    """A sampling head that draws per row: the regression plus noise through ``draw_rows``."""

    row_generators = True

    def step(self, latent, history, state, temperature, generator=None):
        pred, state = super().step(latent, history, state, temperature, generator)
        noise = draw_rows(generator, pred.shape[0], lambda g, n: torch.randn(
            (n, *pred.shape[1:]), generator=g, device=pred.device, dtype=pred.dtype))
        return pred + 0.3 * temperature * noise, state


class PlainNoisyHead(RowNoisyHead):
    """The same head drawing with ``torch.randn`` directly; it does not declare row streams (a declaration
    is not inherited)."""

    def step(self, latent, history, state, temperature, generator=None):
        pred = self.predict(latent)
        noise = torch.randn(pred.shape, generator=generator, device=pred.device, dtype=pred.dtype)
        return pred + 0.3 * temperature * noise, state


class HeadsPlugin:
    @hookimpl
    def register_heads(self, register):
        register("row-noisy-head", RegressionHeadConfig,
                 lambda c, *, motion_dim, latent_dim, **_: RowNoisyHead(c, motion_dim, latent_dim, None))
        register("plain-noisy-head", RegressionHeadConfig,
                 lambda c, *, motion_dim, latent_dim, **_: PlainNoisyHead(c, motion_dim, latent_dim, None))


# --- RowGenerators / draw_rows ---------------------------------------------------------------------

def _rejection(g: torch.Generator, n: int) -> torch.Tensor:
    """A draw whose count of calls depends on the values (as the chi-square rejection loop's)."""
    out = torch.empty(n, 3)
    todo = torch.arange(n)
    while todo.numel():
        x = torch.randn(todo.numel(), 3, generator=g)
        ok = x[:, 0] > 0
        out[todo[ok]] = x[ok]
        todo = todo[~ok]
    return out


@pytest.mark.parametrize("fn", [
    lambda g, n: torch.randn(n, 2, 5, generator=g),
    _rejection,
    lambda g, n: torch.rand(4, n, generator=g).T,  # rows along dim 0 of the result, drawn in another layout
])
def test_row_generators_draw_for_each_group_what_its_generator_draws_alone(fn):
    seeds, rows = [3, 11, 5], [2, 1, 3]
    alone = [fn(torch.Generator().manual_seed(s), n) for s, n in zip(seeds, rows, strict=True)]
    alone2 = [fn(torch.Generator().manual_seed(s), n) for s, n in zip(seeds, rows, strict=True)]
    gens = RowGenerators([torch.Generator().manual_seed(s) for s in seeds], rows)
    assert gens.batch == 6
    first, second = draw_rows(gens, 6, fn), draw_rows(gens, 6, fn)  # the streams advance as alone
    expect1 = torch.cat(alone)
    assert torch.equal(first, expect1)
    expect2 = torch.cat([fn(g, n) for g, n in zip(
        [torch.Generator().manual_seed(s) for s in seeds], rows, strict=True)])  # fresh: the first draw
    assert torch.equal(expect2, expect1) and torch.equal(torch.cat(alone2), expect1)
    singles = []
    for s, n in zip(seeds, rows, strict=True):
        g = torch.Generator().manual_seed(s)
        fn(g, n)
        singles.append(fn(g, n))
    assert torch.equal(second, torch.cat(singles))


def test_same_seed_groups_equal_separate_generators_and_a_plain_generator_is_one_call():
    fn = _rejection
    shared = RowGenerators.same_seed(7, groups=3, rows=2)
    separate = RowGenerators([torch.Generator().manual_seed(7) for _ in range(3)], 2)
    for _ in range(3):
        a, b = draw_rows(shared, 6, fn), draw_rows(separate, 6, fn)
        assert torch.equal(a, b)
        assert torch.equal(a[:2], a[2:4]) and torch.equal(a[:2], a[4:])
    g1, g2 = torch.Generator().manual_seed(4), torch.Generator().manual_seed(4)
    assert torch.equal(draw_rows(g1, 5, fn), fn(g2, 5))
    assert draw_rows(None, 4, lambda g, n: torch.zeros(n)).shape == (4,)
    with pytest.raises(ValueError, match="cover 6 rows"):
        draw_rows(shared, 5, fn)
    g = torch.Generator()
    with pytest.raises(ValueError, match="given twice"):
        RowGenerators([g, g], 1)


def test_row_generator_declarations_are_not_inherited():
    cfg = RegressionHeadConfig()
    assert supports_row_generators(RegressionHead(cfg, 4, 8, None))
    assert supports_row_generators(RowNoisyHead(cfg, 4, 8, None))
    assert not supports_row_generators(PlainNoisyHead(cfg, 4, 8, None))


# --- composition -----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A tiny trained core-synthetic model with a per-row sampling head, and three songs of different lengths."""
    root = tmp_path_factory.mktemp("batch")
    songs = root / "songs"
    songs.mkdir()
    paths = [click_song(songs / f"s{k}.wav", seconds, bpm)
             for k, (seconds, bpm) in enumerate([(1.5, 100), (2.4, 120), (0.9, 90)])]
    with registered_plugin(HeadsPlugin(), "batch-heads"):
        ckpt = train(load_recipe("core-synthetic", TINY), out=str(root / "run"), quiet=True).checkpoint
        yield {"songs": paths, "checkpoint": str(ckpt), "root": root}


def _recipe(*extra: str):
    return load_recipe("core-synthetic", [*TINY, "compose.ground=false", *extra])


def _generate(model, recipe, batched: bool) -> list[np.ndarray]:
    registry = get_registry()
    device = torch.device("cpu")
    net, ckpt, stack = load_model(recipe, model["checkpoint"], device)
    seed = torch.zeros(net.start_frames(), ckpt.motion.dim)
    songs = [load_song(p, stack, ckpt, None, registry) for p in model["songs"]]
    assert len({s.n_frames for s in songs}) == 3
    if batched:
        return generate_songs(net, songs, seed, recipe, device)
    return [generate_song(net, s, seed, recipe, device) for s in songs]


@pytest.mark.parametrize("temperature", [0.0, 1.0])
def test_batched_songs_equal_per_song_generation_within_rounding(model, temperature):
    recipe = _recipe(f"compose.temperature={temperature}", "compose.samples=2")
    with registered_plugin(HeadsPlugin(), "batch-heads"):
        alone = _generate(model, recipe, batched=False)
        batched = _generate(model, recipe, batched=True)
        again = _generate(model, recipe, batched=True)
    for a, b, c in zip(alone, batched, again, strict=True):
        assert a.shape == b.shape  # each song trimmed to its own length
        assert np.abs(a - b).max() <= TOLERANCE
        assert np.array_equal(b, c)  # deterministic for a given batch
    if temperature > 0:  # the noise is real, differs between a song's samples, and is the song's own
        assert np.abs(alone[0][0] - alone[0][1]).max() > 0.05
        assert np.abs(batched[0][0] - batched[0][1]).max() > 0.05


def _npz(folder: Path) -> dict[str, np.ndarray]:
    """The motion values of every NPZ dance in a folder, by file name."""
    out = {}
    for p in sorted(folder.glob("*.npz")):
        with np.load(p) as data:
            out[p.name] = data["values"]
    return out


def _compose(model, out: Path, *extra: str, shard: Shard | None = None, overwrite: bool = True, quiet=True):
    recipe = _recipe("compose.temperature=1", "compose.samples=2", *extra)
    with registered_plugin(HeadsPlugin(), "batch-heads"):
        return compose_songs(recipe, model["songs"], model["checkpoint"], str(out), quiet=quiet,
                             overwrite=overwrite, shard=shard)


def test_compose_with_batch_songs_writes_each_song_close_to_alone_and_per_song_mode_is_unchanged(model, tmp_path):
    alone = tmp_path / "alone"
    for path in model["songs"]:  # each song in its own call: the reference bytes
        recipe = _recipe("compose.temperature=1", "compose.samples=2")
        with registered_plugin(HeadsPlugin(), "batch-heads"):
            compose_songs(recipe, [path], model["checkpoint"], str(alone), quiet=True)
    per_song = _compose(model, tmp_path / "per-song")  # batch_songs defaults to 1
    batched = _compose(model, tmp_path / "batched", "compose.batch_songs=3")
    a, p, b = _npz(alone), _npz(tmp_path / "per-song"), _npz(tmp_path / "batched")
    assert len(a) == 6 and a.keys() == p.keys() == b.keys()
    for name in a:
        assert np.array_equal(a[name], p[name])  # per-song: the same values whatever else is composed
        assert a[name].shape == b[name].shape and np.abs(a[name] - b[name]).max() <= TOLERANCE
    assert batched.frames == per_song.frames and len(batched.written) == 6
    # batches of 2 (the last holds one song) and a second run: deterministic for a given batch composition
    _compose(model, tmp_path / "pairs", "compose.batch_songs=2")
    _compose(model, tmp_path / "pairs2", "compose.batch_songs=2")
    for name, values in _npz(tmp_path / "pairs").items():
        assert np.array_equal(values, _npz(tmp_path / "pairs2")[name])
        assert np.abs(values - a[name]).max() <= TOLERANCE
    assert np.array_equal(_npz(tmp_path / "pairs")["s2-0.npz"], a["s2-0.npz"])  # alone in its batch: the same bytes


def test_batch_songs_skips_complete_songs_and_shards(model, tmp_path):
    out = tmp_path / "out"
    first = _compose(model, out, "compose.batch_songs=3", shard=Shard(1, 2))
    assert [Path(s).name for s in first.songs] == ["s0.wav", "s2.wav"]
    rest = _compose(model, out, "compose.batch_songs=3", overwrite=False)
    assert [Path(s).name for s in rest.skipped] == ["s0.wav", "s2.wav"] and len(rest.written) == 2
    assert sorted(p.name for p in out.glob("*.npz")) == [f"s{k}-{i}.npz" for k in range(3) for i in range(2)]


def test_a_head_without_row_streams_composes_per_song_with_a_note(model, tmp_path, capsys, monkeypatch):
    for folder, k in (("alone", 1), ("asked", 3)):
        if k == 3:
            monkeypatch.setattr(RowNoisyHead, "row_generators", False)  # as a head that draws with torch.randn
        result = _compose(model, tmp_path / folder, f"compose.batch_songs={k}", quiet=False)
        assert len(result.written) == 6
    err = capsys.readouterr().err
    assert err.count("dance: note: compose.batch_songs=3: the head (RowNoisyHead) does not declare") == 1
    assert "one song at a time" in err
    alone, asked = _npz(tmp_path / "alone"), _npz(tmp_path / "asked")
    assert alone.keys() == asked.keys() and all(np.array_equal(alone[n], asked[n]) for n in alone)


def test_a_song_level_encoder_is_not_batched():
    class Model:
        window = Window(cond_past=None)
        encoder = torch.nn.Identity()
        head = RegressionHead(RegressionHeadConfig(), 4, 8, None)

    assert "reads the whole song" in batching_note(Model())
    Model.window = Window(motion_past=2, cond_past=2, cond_future=1)
    assert batching_note(Model()) is None


@pytest.mark.parametrize("bad, batch_songs, raw", [
    (0, 3, b"not audio at all, a text file"),
    (1, 3, b"RIFF" + b"\x00" * 40),
    (2, 2, b"\x00" * 100),  # alone in the second batch
    (1, 2, b"RIFF\x24\x00\x00\x00WAVEfmt \x10\x00\x00\x00\x01\x00\x01\x00\x00\x00\x00\x00"),  # rate 0
], ids=["text-first-of-3", "riff-zeros-middle-of-3", "zeros-alone", "rate-0-second-of-2"])
def test_keep_going_lists_only_the_bad_song_of_a_batch(model, tmp_path, bad, batch_songs, raw):
    """Issue 28: one bad song fails its batch; the batch is composed again a song at a time, so the songs
    beside it are written (as they would be alone) and only the bad one is listed."""
    import shutil

    from dance_core.compose import ComposeOptions, resolve_inputs, run_compose

    songs = []
    for k, path in enumerate(model["songs"]):
        songs.append(tmp_path / "songs" / Path(path).name)
        songs[-1].parent.mkdir(exist_ok=True)
        shutil.copyfile(path, songs[-1]) if k != bad else songs[-1].write_bytes(raw)
    recipe = _recipe("compose.temperature=1", "compose.samples=2", f"compose.batch_songs={batch_songs}")
    with registered_plugin(HeadsPlugin(), "batch-heads"):
        options = ComposeOptions(music=[str(s) for s in songs], checkpoint=model["checkpoint"],
                                 out_dir=str(tmp_path / "out"), keep_going=True, quiet=True)
        result = run_compose(resolve_inputs(recipe, options))
        alone = _compose(model, tmp_path / "alone")  # every good song in its own batch
    assert [Path(song).name for song, _ in result.failed] == [f"s{bad}.wav"]
    assert str(songs[bad]) in result.failed[0][1]
    good = [f"s{k}-{i}.npz" for k in range(3) if k != bad for i in range(2)]
    written, reference = _npz(tmp_path / "out"), _npz(tmp_path / "alone")
    assert sorted(written) == good and alone.written
    for name in good:
        assert np.abs(written[name] - reference[name]).max() <= TOLERANCE
