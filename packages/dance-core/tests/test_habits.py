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


def test_quiet_train_prints_the_checkpoint_alone(tmp_path, capsys):
    assert main(["-q", "train", "core-synthetic", *TINY, "-o", str(tmp_path / "run")]) == 0
    out, err = capsys.readouterr()
    assert out.strip().splitlines() == [str(tmp_path / "run" / "model.safetensors")] and err == ""
    assert main(["train", "core-synthetic", *TINY, "-o", str(tmp_path / "run2")]) == 0
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
