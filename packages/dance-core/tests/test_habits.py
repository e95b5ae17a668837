"""Issue 28, the habits a new user expects: --keep-going for catalogues, -q quiet, --json on every command
(errors included), "did you mean", wheel metadata, the test extra holding hypothesis."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.formats.wav import write_wav

ROOT = Path(__file__).resolve().parents[3]
TINY = [arg for s in ("data.dataset.songs=4", "data.dataset.seconds=6", "training.steps=20", "training.batch_size=16",
                      "training.val_every=20", "training.checkpoint_every=20", "training.log_every=10")
        for arg in ("--set", s)]


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    assert main(["-q", "train", "core-synthetic", *TINY, "-o", str(run)]) == 0
    return run / "model.safetensors"


def _catalogue(folder: Path, bad: dict[str, bytes]) -> None:
    folder.mkdir()
    for name in ("a.wav", "c.wav", "e.wav"):
        write_wav(folder / name, np.random.default_rng(len(name)).uniform(-0.3, 0.3, 16000), 8000)
    for name, raw in bad.items():
        (folder / name).write_bytes(raw)


BAD_SONGS = [
    {"b.wav": b"not audio at all, a text file"},
    {"b.wav": b"RIFF\x24\x00\x00\x00WAVEfmt \x10\x00\x00\x00\x01\x00\x01\x00\x00\x00\x00\x00"},  # rate 0, cut short
    {"b.wav": b"RIFF" + b"\x00" * 40, "d.wav": b"\x00" * 100},
]


@pytest.mark.parametrize("bad", BAD_SONGS)
def test_keep_going_writes_the_good_songs_and_lists_the_bad_ones_at_the_end(tmp_path, capsys, checkpoint, bad):
    _catalogue(tmp_path / "songs", bad)
    out = tmp_path / "out"
    argv = ["compose", "core-synthetic", "--checkpoint", str(checkpoint), "--music", str(tmp_path / "songs"),
            "-o", str(out), "--keep-going"]
    assert main(["-q", *argv]) == 1
    captured = capsys.readouterr()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["a.npz", "c.npz", "e.npz"]
    errors = captured.err.strip().splitlines()
    assert [line.split(": ")[2] for line in errors[:-1]] == [str(tmp_path / "songs" / n) for n in sorted(bad)]
    assert errors[-1] == f"dance: error: {len(bad)} song(s) failed, the others written (--keep-going)"
    assert main(["-q", *argv, "--json"]) == 1  # the rerun skips the written songs, lists the bad ones again
    data = json.loads(capsys.readouterr().out)
    assert data["exit_code"] == 1 and data["error"].startswith(f"{len(bad)} song(s) failed")
    assert [f["song"] for f in data["failed_songs"]] == [str(tmp_path / "songs" / n) for n in sorted(bad)]
    assert len(data["skipped_songs"]) == 3 and data["written_songs"] == []
    assert main(["-q", *argv[:-1]]) == 1  # without --keep-going: stops at the first bad song
    assert "failed, the others written" not in capsys.readouterr().err


@pytest.mark.parametrize("bad", ["0.wav", "z.wav"])
def test_keep_going_with_progress_shown_lists_a_bad_song_first_or_last(tmp_path, capsys, checkpoint, bad):
    _catalogue(tmp_path / "songs", {bad: b"not audio at all, a text file"})
    out = tmp_path / "out"
    code = main(["compose", "core-synthetic", "--checkpoint", str(checkpoint), "--music", str(tmp_path / "songs"),
                 "-o", str(out), "--keep-going"])
    captured = capsys.readouterr()
    assert code == 1 and "Traceback" not in captured.err and "Error:" not in captured.err, captured.err
    assert f"dance: error: {tmp_path / 'songs' / bad}: cannot decode audio" in captured.err
    assert captured.err.strip().splitlines()[-1].endswith("1 song(s) failed, the others written (--keep-going)")
    assert len([p for p in out.iterdir() if p.suffix == ".npz"]) == 3 and bad.replace(".wav", ".npz") not in \
        captured.out


def test_quiet_train_prints_nothing_and_json_still_names_the_checkpoint(tmp_path, capsys):
    assert main(["-q", "train", "core-synthetic", *TINY, "-o", str(tmp_path / "run")]) == 0
    assert capsys.readouterr() == ("", "") and (tmp_path / "run" / "model.safetensors").is_file()
    assert main(["-q", "train", "core-synthetic", *TINY, "-o", str(tmp_path / "run2"), "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["output"][-1] == str(tmp_path / "run2" / "model.safetensors") and err == ""
    assert main(["train", "core-synthetic", *TINY, "-o", str(tmp_path / "run3")]) == 0
    assert "trained 20 steps" in capsys.readouterr().out


JSON_CASES = [  # (argv, exit code, a key or the words of the error)
    (["recipe", "validate", "core-synthetic", "--json"], 0, "output"),
    (["recipe", "show", "core-synthetic", "--json"], 0, "output"),
    (["--json", "recipe", "list"], 0, "output"),
    (["recipe", "list", "--json"], 0, None),  # its own JSON, unchanged
    (["plugins", "--json"], 0, None),
    (["synth", "{t}/x.wav", "--seconds", "1", "--json"], 0, "output"),
    (["recipe", "validate", "no-such-recipe", "--json"], 1, "no-such-recipe: no such recipe file"),
    (["recipe", "validate", "core-synthetic", "--set", "training.stepz=1", "--json"], 1, "did you mean 'steps'"),
    (["synth", "{t}/x.wav", "--seconds", "0", "--json"], 2, "argument --seconds: must be above 0"),
    (["render", "{t}/missing.bvh", "-o", "{t}/x.html", "--json"], 1, "motion file not found"),
    (["train", "core-synthetic", "--stop-at", "0", "--json"], 2, "argument --stop-at"),
    (["compose", "core-synthetic", "--music", "{t}/missing.wav", "--json"], 1, "audio file not found"),
    (["evaluate", "--generated", "{t}/none", "--reference", "{t}/none", "--json"], 1, "not found"),
    (["plugin", "new", "Bad_Name", "--kind", "head", "--out", "{t}", "--json"], 1, "plugin name 'Bad_Name'"),
    (["retarget", "{t}/missing.bvh", "--json"], 2, "error"),
]


@pytest.mark.parametrize("argv, code, words", JSON_CASES)
def test_json_on_every_command_errors_included(tmp_path, capsys, argv, code, words):
    assert main([a.replace("{t}", str(tmp_path)) for a in argv]) == code
    out, err = capsys.readouterr()
    data = json.loads(out)  # stdout is one JSON value, whatever happened
    if code == 0:
        assert words is None or words in data
        return
    assert data["exit_code"] == code and (words == "error" or words in data["error"]), data
    assert "error" in err  # the line for people is still on stderr


@pytest.mark.parametrize("name, hint", [
    ("core-synthetc", "did you mean 'core-synthetic'"), ("defualt", "did you mean 'default'"),
    ("tm2d-smal", "did you mean 'tm2d-small'"), ("zzzz", None),
])
def test_did_you_mean_for_recipe_names(capsys, name, hint):
    assert main(["recipe", "validate", name]) == 1
    err = capsys.readouterr().err
    assert "no such recipe file or bundled recipe" in err and ((hint in err) if hint else "did you mean" not in err)


@pytest.mark.parametrize("assignment, hint", [
    ("training.stepz=3", "training.stepz: unknown field (did you mean 'steps'?)"),
    ("training.batchsize=3", "(did you mean 'batch_size' or"),
    ("compose.formt=[npz]", "(did you mean 'formats'?)"),
    ("model.head.los=l2", "(did you mean 'loss'?)"),
    ("model.encoder.hiden=8", "(did you mean 'hidden'?)"),
    ("training.zzzz=1", "training.zzzz: unknown field\n"),
])
def test_did_you_mean_for_set_field_paths(capsys, assignment, hint):
    assert main(["recipe", "validate", "core-synthetic", "--set", assignment]) == 1
    assert hint in capsys.readouterr().err


@pytest.mark.parametrize("package", ["dance-core", "dance-audio", "dance-flow", "dance-rnn", "dance-tokens"])
def test_every_wheel_carries_its_licence_and_classifiers(package):
    project = tomllib.loads((ROOT / "packages" / package / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT" and (ROOT / "packages" / package / "LICENSE").is_file()
    assert "Programming Language :: Python :: 3" in project["classifiers"] and project["keywords"]
    assert all(c.count(" :: ") >= 1 for c in project["classifiers"])


def test_the_test_extra_and_the_pinned_environment_hold_hypothesis():
    extra = tomllib.loads((ROOT / "packages/dance-core/pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert any(r.startswith("hypothesis") for r in extra["test"])
    pins = (ROOT / "requirements-dev.txt").read_text()
    assert "\nhypothesis==" in pins and "packages/dance-core[plots,render,test]" in pins


def _complete(line: str, tmp_path) -> list[str]:
    import os
    import subprocess
    import sys

    out = tmp_path / "completions.txt"
    env = {**os.environ, "COMP_LINE": line, "COMP_POINT": str(len(line)), "_ARGCOMPLETE": "1",
           "_ARGCOMPLETE_STDOUT_FILENAME": str(out)}
    subprocess.run([sys.executable, "-m", "dance_core.cli.main"], env=env, capture_output=True, timeout=120)
    return out.read_text().replace("\x0b", "\n").split() if out.exists() else []


@pytest.mark.parametrize("line, expected", [
    ("dance comp", ["compose"]),
    ("dance compose tm2", ["tm2d", "tm2d-small"]),
    ("dance recipe validate core-", ["core-dance", "core-synthetic"]),
    ("dance compose default --keep", ["--keep-going", "--keep"]),
])
def test_shell_completion_of_commands_options_and_recipes(tmp_path, line, expected):
    pytest.importorskip("argcomplete")
    assert set(expected) <= set(_complete(line, tmp_path))


def test_install_completion_prints_the_shell_code(capsys):
    pytest.importorskip("argcomplete")
    with pytest.raises(SystemExit) as done:
        main(["--install-completion"])
    assert done.value.code == 0 and "complete" in capsys.readouterr().out


# ------------------------------------------------------------------ -q: nothing but errors and warnings

QUICK = [arg for s in ("data.dataset.songs=2", "data.dataset.seconds=4", "training.steps=2", "training.batch_size=8",
                       "training.val_every=2", "training.checkpoint_every=2", "training.log_every=1")
         for arg in ("--set", s)]


@pytest.fixture(scope="module")
def quiet_inputs(tmp_path_factory, checkpoint):
    """A 3-s click song, a one-song synthetic dataset (its BVH) and a tiny skeletal model (core-dance)."""
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    folder = tmp_path_factory.mktemp("quiet")
    assert main(["-q", "synth", str(folder / "song.wav"), "--seconds", "3", "--rate", "8000"]) == 0
    assert main(["-q", "synth", "--out", str(folder / "data"), "--songs", "1", "--seconds", "2", "--rate", "8000",
                 "--fps", "30"]) == 0
    train(load_recipe("core-dance", [s for s in QUICK if s != "--set"]), out=str(folder / "dance"), quiet=True)
    return {"s": folder / "song.wav", "d": folder / "data", "b": folder / "data" / "synth-0000.bvh",
            "c": checkpoint, "k": folder / "dance" / "model.safetensors"}


QUIET_CASES = [  # (argv, a file the command writes, or None; "{t}" is a fresh folder)
    (["compose", "core-synthetic", "--checkpoint", "{c}", "--music", "{s}", "-o", "{t}/o"], "o/song.npz"),
    (["compose", "core-dance", "--checkpoint", "{k}", "--music", "{s}", "-o", "{t}/o", "--markers", "--format", "bvh",
      "--format", "html"], "o/song.markers.json"),
    (["train", "core-synthetic", *QUICK, "-o", "{t}/run"], "run/model.safetensors"),
    (["synth", "{t}/x.wav", "--seconds", "1", "--rate", "8000"], "x.wav"),
    (["synth", "--out", "{t}/data", "--songs", "1", "--seconds", "2", "--rate", "8000", "--fps", "30"],
     "data/synth-0000.bvh"),
    (["evaluate", "--generated", "{d}", "--reference", "{d}", "-o", "{t}/r.json", "--no-plots"], "r.json"),
    (["render", "{b}", "-o", "{t}/x.html"], "x.html"),
    (["render", "{b}", "-o", "{t}/x.gif", "--size", "32", "32", "--seconds", "0.3"], "x.gif"),
    (["retarget", "{b}", "--to", "dance24", "-o", "{t}/r.bvh"], "r.bvh"),
    (["convert", "{b}", "-o", "{t}/c.glb", "--markers"], "c.markers.json"),
    (["convert", "--blender-script", "{t}/s.py"], "s.py"),
    (["recipe", "validate", "core-synthetic"], None),
    (["recipe", "schema", "-o", "{t}/schema.json"], "schema.json"),
    (["plugin", "new", "mine", "--kind", "head", "--out", "{t}"], "dance-mine/pyproject.toml"),
    (["features", "{s}", "-x", "energy", "-o", "{t}/f.npz"], "f.npz"),
]


def _fill(argv: list[str], tmp_path, inputs: dict) -> list[str]:
    values = {"t": str(tmp_path), **{k: str(v) for k, v in inputs.items()}}
    return [a.format_map(values) if "{" in a else a for a in argv]


@pytest.mark.parametrize("where", ["before", "after"])
@pytest.mark.parametrize("argv, written", QUIET_CASES, ids=[" ".join(c[0][:2]) for c in QUIET_CASES])
def test_quiet_prints_nothing_on_success(tmp_path, capsys, quiet_inputs, argv, written, where):
    from dance_core.cli.main import build_parser

    if argv[0] not in build_parser()._subparsers._group_actions[0].choices:
        pytest.skip(f"no installed plugin adds dance {argv[0]}")
    argv = _fill(argv, tmp_path, quiet_inputs)
    assert main(["-q", *argv] if where == "before" else [*argv, "-q"]) == 0
    assert capsys.readouterr() == ("", "")
    assert written is None or (tmp_path / written).is_file()


ASKED_CASES = [  # what the user asked to see is printed under -q too; stderr stays empty
    (["recipe", "show", "core-synthetic"], "name: core-synthetic"),
    (["recipe", "list"], "core-synthetic"),
    (["recipe", "list", "--json"], '"name": "core-synthetic"'),
    (["recipe", "schema"], '"$defs"'),
    (["plugins"], "recipe\tcore-synthetic"),
    (["render", "{b}", "-o", "{t}/x.html", "--json"], '"output": [\n    "{t}/x.html (60 frames)"'),
    (["compose", "core-synthetic", "--checkpoint", "{c}", "--music", "{s}", "-o", "{t}/o", "--json"],
     '"files": [\n    "{t}/o/song.npz"'),
    (["live", "core-dance", "--checkpoint", "{k}", "--input", "{s}", "--speed", "50", "--output", "-"],
     '{"skeleton":{"name":"dance24"'),
]


@pytest.mark.parametrize("argv, shown", ASKED_CASES, ids=[" ".join(c[0][:2]) for c in ASKED_CASES])
def test_quiet_still_prints_what_was_asked_for(tmp_path, capsys, quiet_inputs, argv, shown):
    assert main(["-q", *_fill(argv, tmp_path, quiet_inputs)]) == 0
    out, err = capsys.readouterr()
    assert shown.replace("{t}", str(tmp_path)) in out and err == ""


# ------------------------------------------------------------- summaries count every file they wrote

COUNT_CASES = [  # (argv, what the summary says the count is, whether every file is named) in a fresh folder {t}
    (["compose", "core-dance", "--checkpoint", "{k}", "--music", "{s}", "-o", "{t}", "--markers", "--format", "bvh",
      "--format", "html"], r"(\d+) file\(s\) \(1 \.bvh, 1 \.html, 1 \.markers\.json\) in", True),
    (["compose", "core-synthetic", "--checkpoint", "{c}", "--music", "{s}", "-o", "{t}", "--samples", "2"],
     r"(\d+) file\(s\) in", True),
    (["synth", "--out", "{t}", "--songs", "1", "--seconds", "2", "--rate", "8000", "--fps", "30"],
     r": (\d+) files, 1 song\(s\) \(synth-0000 \.\.\. synth-0000\), each \.wav \.bvh \.beats \.texts \.sections",
     False),
    (["synth", "--out", "{t}", "--songs", "2", "--dances", "2", "--seconds", "2", "--rate", "8000", "--fps", "30"],
     r": (\d+) files, 2 song\(s\) x 2 dances", False),
    (["synth", "--out", "{t}", "--music", "{s}", "--dances", "2", "--fps", "30"], r": (\d+) files, 2 dance\(s\)",
     False),
    (["convert", "{b}", "-o", "{t}/c.bvh", "--markers"], None, True),
    (["render", "{b}", "-o", "{t}/x.html", "-o", "{t}/y.html"], None, True),
    (["evaluate", "--generated", "{d}", "--reference", "{d}", "-o", "{t}/r.json", "--plots", "{t}/plots"],
     r"and (\d+) plot\(s\) in", False),
    (["plugin", "new", "mine", "--kind", "head", "--out", "{t}"], r"\((?:head 'mine'), (\d+) files\)", False),
]


@pytest.mark.parametrize("argv, count, named", COUNT_CASES, ids=[" ".join(c[0][:2]) for c in COUNT_CASES])
def test_a_summary_counts_every_file_written(tmp_path, capsys, quiet_inputs, argv, count, named):
    import re

    if argv[0] == "synth" and "--music" in argv:
        from dance_core.data.beat_tracking import beat_tracker
        from dance_core.registry import get_registry

        if beat_tracker(get_registry()) is None:
            pytest.skip("no beat tracker installed (dance-audio)")
    if argv[0] == "evaluate":
        pytest.importorskip("matplotlib")
    code = main(_fill(argv, tmp_path, quiet_inputs))
    out, err = capsys.readouterr()
    assert code == 0, err
    files = sorted(p for p in tmp_path.rglob("*") if p.is_file() and not p.name.startswith("."))
    report = out + err
    if argv[0] == "evaluate":  # the report is named; the plots are counted
        files = [p for p in files if p.parent.name == "plots"]
    assert files
    if count is not None:
        # the console wraps long lines (the paths here are long), so any space of the pattern may be a line break
        assert int(re.search(count.replace(" ", r"\s+"), report).group(1)) == len(files), report
    if named:
        assert all(str(p) in report or p.name in report for p in files), report
