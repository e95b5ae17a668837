"""Issue 15, composition at scale: folders of songs, every song written once, complete output sets skipped
(``--overwrite`` to redo), ``--shard I/N`` splitting the path-sorted songs with no coordination, and a
song's dance the same bytes whatever it is sharded with."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.compose import audio_files, complete, compose_songs, expand_music
from dance_core.errors import DataError
from dance_core.registry import get_registry
from dance_core.shards import Shard
from dance_core.testing import registered_plugin
from dance_core.train import train

sys.path.insert(0, str(Path(__file__).parent))
from compose_helpers import NoisyPlugin, click_song  # noqa: E402

TINY = ["data.dataset.songs=4", "data.dataset.seconds=6", "training.steps=10", "training.batch_size=16",
        "training.val_every=10", "training.checkpoint_every=10", "training.log_every=10",
        "model.head.plugin=noisy-head"]


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    """A tiny trained sampling model and a folder of five songs of different lengths and tempi."""
    from dance_core.recipe import load_recipe

    root = tmp_path_factory.mktemp("scale")
    songs = root / "songs"
    songs.mkdir()
    for k, (seconds, bpm) in enumerate([(1.5, 100), (2.0, 120), (1.2, 90), (2.5, 130), (1.8, 110)]):
        click_song(songs / f"s{k}.wav", seconds, bpm)
    (songs / "notes.txt").write_text("not a song")
    (songs / ".s9.wav.dance-1-abcdefgh.wav").write_bytes(b"a temporary file")
    with registered_plugin(NoisyPlugin(), "noisy-plugin"):
        ckpt = train(load_recipe("core-synthetic", TINY), out=str(root / "run"), quiet=True).checkpoint
        yield {"songs": songs, "checkpoint": str(ckpt), "root": root}


def run_compose(noisy, out: Path, *extra: str) -> tuple[int, dict]:
    args = ["compose", "core-synthetic", "--checkpoint", noisy["checkpoint"], "-o", str(out), "--samples", "2",
            "--temperature", "1", "--json", "-q", *[a for s in TINY for a in ("--set", s)], *extra]
    with registered_plugin(NoisyPlugin(), "noisy-plugin"):
        rc = main(args)
    return rc


def files(folder: Path) -> dict[str, bytes]:
    """The outputs in ``folder`` (not the hidden manifests that record each song's committed set)."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if not p.name.startswith(".")}


def test_shard_parse_and_select_partition_the_sorted_songs():
    assert Shard.parse("2/3") == Shard(2, 3) and str(Shard.parse(" 1/1 ")) == "1/1"
    for bad in ("0/3", "4/3", "1/0", "3", "a/b", "1/2/3", "-1/2", "1.5/2", ""):
        with pytest.raises(ValueError, match="expected I/N"):
            Shard.parse(bad)
    songs = [f"/m/{name}.ogg" for name in "dbeacgf"]
    parts = [Shard(i, 3).select(songs) for i in (1, 2, 3)]
    assert parts == [["/m/a.ogg", "/m/d.ogg", "/m/g.ogg"], ["/m/b.ogg", "/m/e.ogg"], ["/m/c.ogg", "/m/f.ogg"]]
    assert sorted(sum(parts, [])) == sorted(songs)  # every song in exactly one part
    assert Shard(1, 1).select(songs) == sorted(songs)
    assert Shard(5, 9).select(songs) == ["/m/e.ogg"] and Shard(9, 9).select(songs) == []


def test_bad_shard_is_one_usage_line(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["compose", "default", "--music", "x.ogg", "--shard", "3/2"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == ("dance compose: error: argument --shard: expected I/N with 1 <= I <= N, got '3/2' "
                   "(see dance compose --help)")


def test_a_folder_stands_for_its_audio_files(noisy, tmp_path):
    registry = get_registry()
    found = audio_files(noisy["songs"], registry)
    assert [Path(p).name for p in found] == [f"s{k}.wav" for k in range(5)]  # sorted; no .txt, no temp file
    single = click_song(tmp_path / "z.wav", 1.0)
    assert expand_music([single, str(noisy["songs"])], registry) == [single, *found]
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match=r"empty: no audio files in this folder \(suffixes read: .*\.wav"):
        audio_files(tmp_path / "empty", registry)


def test_sharded_folder_composition_equals_the_unsharded_byte_for_byte(noisy, tmp_path, capsys):
    assert run_compose(noisy, tmp_path / "all", "--music", str(noisy["songs"])) == 0
    summary = json.loads(capsys.readouterr().out)
    assert len(summary["written_songs"]) == 5 and summary["skipped_songs"] == [] and summary["shard"] is None
    assert summary["frames"] == 2 * sum(round(s * 20) for s in (1.5, 2.0, 1.2, 2.5, 1.8))
    assert summary["seconds"] == pytest.approx(summary["frames"] / 20) and summary["frames_per_second"] > 0
    for i in (1, 2):  # two machines, one folder, any order
        assert run_compose(noisy, tmp_path / "sharded", "--music", str(noisy["songs"]), "--shard", f"{i}/2") == 0
        part = json.loads(capsys.readouterr().out)
        assert part["shard"] == f"{i}/2" and len(part["written_songs"]) == (3 if i == 1 else 2)
    # the songs given as files, in another order, three shards
    given = [str(p) for p in sorted(noisy["songs"].glob("s*.wav"), reverse=True)]
    for i in (3, 1, 2):
        assert run_compose(noisy, tmp_path / "thirds", "--music", *given, "--shard", f"{i}/3") == 0
    capsys.readouterr()
    whole = files(tmp_path / "all")
    assert sorted(whole) == sorted(f"s{k}-{j}.npz" for k in range(5) for j in range(2))
    assert files(tmp_path / "sharded") == whole == files(tmp_path / "thirds")
    with np.load(tmp_path / "all" / "s1-0.npz") as f0, np.load(tmp_path / "all" / "s1-1.npz") as f1:
        assert not np.array_equal(f0["values"], f1["values"])  # the samples are random draws


def test_complete_songs_are_skipped_an_incomplete_one_redone_and_overwrite_redoes_all(noisy, tmp_path, capsys):
    out = tmp_path / "out"
    assert run_compose(noisy, out, "--music", str(noisy["songs"]), "--format", "npz") == 0
    capsys.readouterr()
    first = files(out)
    assert len(first) == 10
    stamp = 1_000_000_000
    for p in out.iterdir():
        os.utime(p, (stamp, stamp))
    (out / "s3-1.npz").unlink()  # as if a kill had split s3's set
    (out / "s0-0.npz").write_bytes(b"")  # an empty file is not a complete output
    assert run_compose(noisy, out, "--music", str(noisy["songs"]), "--format", "npz") == 0
    again = json.loads(capsys.readouterr().out)
    assert [Path(s).name for s in again["written_songs"]] == ["s0.wav", "s3.wav"]
    assert [Path(s).name for s in again["skipped_songs"]] == ["s1.wav", "s2.wav", "s4.wav"]
    assert sorted(Path(f).name for f in again["files"]) == ["s0-0.npz", "s0-1.npz", "s3-0.npz", "s3-1.npz"]
    assert files(out) == first
    assert {p.name for p in out.iterdir() if p.stat().st_mtime == stamp and p.suffix == ".npz"} == {
        f"s{k}-{j}.npz" for k in (1, 2, 4) for j in range(2)}  # untouched
    assert run_compose(noisy, out, "--music", str(noisy["songs"]), "--format", "npz") == 0
    nothing = json.loads(capsys.readouterr().out)
    assert nothing["written_songs"] == [] and nothing["files"] == [] and nothing["frames_per_second"] is None
    assert run_compose(noisy, out, "--music", str(noisy["songs"]), "--format", "npz", "--overwrite") == 0
    redo = json.loads(capsys.readouterr().out)
    assert len(redo["written_songs"]) == 5 and len(redo["files"]) == 10
    assert files(out) == first


def test_summary_line_names_written_skipped_and_the_shard(noisy, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["compose", "core-synthetic", "--checkpoint", noisy["checkpoint"], "-o", str(out), "--music",
            str(noisy["songs"]), "--shard", "2/2", *[a for s in TINY for a in ("--set", s)]]
    with registered_plugin(NoisyPlugin(), "noisy-plugin"):
        assert main(args) == 0
        printed, err = capsys.readouterr()
        assert printed.split() == [str(out / "s1.npz"), str(out / "s3.npz")]
        assert f"composed 2 song(s) x 1: 4.5 s of dance, 2 file(s) in {out}, " in err
        assert err.rstrip().endswith("frames/s; shard 2/2 holds 2 song(s)")
        assert main(args) == 0
        printed, err = capsys.readouterr()
        assert printed == ""
        assert "composed 0 song(s) x 1: 0.0 s of dance, 0 file(s)" in err
        assert "2 song(s) skipped, already complete (--overwrite to redo); shard 2/2" in err


def test_an_empty_file_in_a_folder_stops_the_command_before_any_work(noisy, tmp_path, capsys):
    songs = tmp_path / "songs"
    songs.mkdir()
    click_song(songs / "a.wav", 1.0)
    (songs / "b.wav").write_bytes(b"")
    assert run_compose(noisy, tmp_path / "out", "--music", str(songs)) == 1
    assert capsys.readouterr().err.strip() == f"dance: error: --music {songs / 'b.wav'}: audio file is empty"
    assert not (tmp_path / "out").exists()


def test_songs_with_one_name_are_refused_across_shards(noisy, tmp_path):
    (tmp_path / "x").mkdir()
    twin = click_song(tmp_path / "x" / "s2.wav", 1.0)
    with registered_plugin(NoisyPlugin(), "noisy-plugin"):
        from dance_core.recipe import load_recipe

        recipe = load_recipe("core-synthetic", TINY)
        with pytest.raises(DataError, match="has the same name"):  # even when they would land in different shards
            compose_songs(recipe, [str(noisy["songs"]), twin], noisy["checkpoint"], str(tmp_path / "o"), True,
                          shard=Shard(1, 6))
    assert not (tmp_path / "o").exists()


def test_complete_needs_the_committed_manifest_and_every_file_at_its_size(tmp_path):
    from dance_core.atomic import OutputSet

    a, b, manifest = tmp_path / "a.npz", tmp_path / "b.npz", tmp_path / ".a.outputs.json"
    a.write_bytes(b"x")
    b.write_bytes(b"y")
    assert not complete([a, b], manifest)  # files there, but no committed set says they belong together
    with OutputSet(manifest) as out:
        out.path(a).write_bytes(b"new a")
        out.path(b).write_bytes(b"new b")
    assert complete([a, b], manifest)
    assert not complete([a], manifest) and not complete([a, b, tmp_path / "c.npz"], manifest)
    b.write_bytes(b"old")  # one file of the set replaced since: not whole
    assert not complete([a, b], manifest)
