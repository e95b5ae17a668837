"""Bad input to every command: one error line naming the argument, no traceback, nothing written.

``CASES`` is the bad-input corpus listed in docs/reliability.md ("Bad input"). Each case runs in-process
in a fresh working folder ``{o}``; ``{a}`` holds the inputs (a short song, a BVH dance, an empty file,
a text file named .mp3, an empty recipe, a folder and a plain file ``text.txt`` to put where a folder
goes). Every case must fail before any heavy work, so the corpus stays fast.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main

# (command line, text the one error line must hold); {a}: the inputs, {o}: the working folder
CASES: list[tuple[str, str]] = [
    # compose
    ("compose default --music {a}/missing.wav -o {o}/out", "missing.wav: audio file not found"),
    ("compose default --music {a}/folder -o {o}/out",
     "--music {a}/folder: no audio files in this folder (suffixes read: "),
    ("compose default --music {a}/empty.wav -o {o}/out", "--music {a}/empty.wav: audio file is empty"),
    ("compose default --music {a}/song.wav --samples 0", "argument --samples: must be between 1 and 1000"),
    ("compose default --music {a}/song.wav --temperature -1", "argument --temperature: must be at least 0"),
    ("compose default --music {a}/song.wav --temperature nan", "argument --temperature: must be a finite"),
    ("compose default --music {a}/song.wav --seconds 0", "argument --seconds: must be above 0"),
    ("compose default --music {a}/song.wav --checkpoint {a}/folder -o {o}/out",
     "--checkpoint {a}/folder: is a folder, not a checkpoint"),
    ("compose default --music {a}/song.wav --checkpoint {a}/missing.safetensors -o {o}/out",
     "--checkpoint {a}/missing.safetensors: checkpoint not found"),
    ("compose default --music {a}/song.wav -o {a}/text.txt", "-o {a}/text.txt: is a file, not a folder"),
    ("compose default --music {a}/song.wav -o {a}/text.txt/out", "-o {a}/text.txt/out: {a}/text.txt is a file"),
    ("compose default --music {a}/song.wav --seed-motion {a}/missing.bvh -o {o}/out",
     "--seed-motion {a}/missing.bvh: motion file not found"),
    ("compose default --music {a}/song.wav --text '5-1: jump' -o {o}/out", "--text '5-1: jump'"),
    ("compose {a}/empty.yaml --music {a}/song.wav", "{a}/empty.yaml: recipe file is empty"),
    ("compose no-such-recipe --music {a}/song.wav", "no-such-recipe: no such recipe file or bundled recipe"),
    ("compose default --music {a}/song.wav --set compose.samples=0 -o {o}/out", "compose.samples"),
    # train
    ("train core-synthetic --stop-at -3 -o {o}/run", "argument --stop-at: must be at least 1, got -3"),
    ("train core-synthetic --stop-at 0 -o {o}/run", "argument --stop-at: must be at least 1, got 0"),
    ("train core-synthetic --stop-at 99999 -o {o}/run", "--stop-at 99999: the run has"),
    ("train core-synthetic -o {a}/text.txt", "-o {a}/text.txt: is a file, not a folder"),
    ("train core-synthetic --resume -o {o}/run", "--resume: -o {o}/run: run folder not found"),
    ("train core-synthetic --set training.steps=0 -o {o}/run", "training.steps"),
    ("train {a}/folder", "{a}/folder: is a folder, not a recipe file"),
    # synth
    ("synth {o}/x.wav --rate 2000000000", "argument --rate: must be between 8000 and 192000 Hz"),
    ("synth {o}/x.wav --rate 100", "argument --rate: must be between 8000 and 192000 Hz"),
    ("synth {o}/x.wav --seconds 0", "argument --seconds: must be above 0"),
    ("synth {o}/x.wav --seconds 1e9", "argument --seconds: must be above 0 and at most 3600 s"),
    ("synth {o}/x.wav --seconds nan", "argument --seconds: must be a finite number"),
    ("synth {o}/x.wav --bpm 1000", "argument --bpm: must be between 20 and 400"),
    ("synth {o}/x.wav --rate abc", "argument --rate: expected a whole number"),
    ("synth {o}/x.wav --out {o}/data", "give either FILE.wav"),
    ("synth --out {o}/data --songs 0", "argument --songs: must be between 1 and 100000"),
    ("synth --out {o}/data --jobs 0", "argument --jobs: must be between 1 and 256"),
    ("synth --out {o}/data --music {a}/song.wav --dances 0", "argument --dances: must be between 1 and 1000"),
    ("synth --out {o}/data --seconds 1", "--seconds 1: a dataset song needs at least 2 s"),
    ("synth --out {a}/text.txt", "--out {a}/text.txt: is a file, not a folder"),
    ("synth --out {o}/data --music {a}/missing.wav", "--music {a}/missing.wav: no such file or folder"),
    ("synth --music {a}/song.wav", "--music needs --out DIR"),
    ("synth {a}/folder", "{a}/folder: is a folder; give a file name inside it"),
    ("synth {o}/x.txt", "{o}/x.txt: a click track is a .wav file"),
    # features (dance-audio)
    ("features {a}/missing.wav -o {o}/f.npz", "{a}/missing.wav: audio file not found"),
    ("features {a}/folder -o {o}/f.npz", "{a}/folder: is a folder, not an audio file"),
    ("features {a}/empty.wav -o {o}/f.npz", "{a}/empty.wav: audio file is empty"),
    ("features {a}/fake.mp3 -o {o}/f.npz", "{a}/fake.mp3: cannot decode audio"),  # never "does not exist"
    ("features {a}/song.wav -o {o}/f.npz --fps 1e6", "argument --fps: must be above 0 and at most 1000"),
    ("features {a}/song.wav -o {o}/f.npz --fps 0", "argument --fps: must be above 0"),
    ("features {a}/song.wav -o {a}/folder", "-o {a}/folder: is a folder"),
    ("features {a}/song.wav -o {o}/f.npz -x nosuch", "unknown feature 'nosuch'"),
    ("features {a}/song.wav -o {o}/f.npz --plot {a}/folder", "--plot {a}/folder: is a folder"),
    # render
    ("render {a}/missing.bvh -o {o}/x.html", "{a}/missing.bvh: motion file not found"),
    ("render {a}/folder -o {o}/x.html", "{a}/folder: is a folder, not a motion file"),
    ("render {a}/dance.bvh -o {o}/x.gif --size 0 0", "argument --size: must be between 16 and 8192 pixels"),
    ("render {a}/dance.bvh -o {o}/x.gif --size 100000 100", "argument --size: must be between 16 and 8192"),
    ("render {a}/dance.bvh -o {o}/x.gif --fps -1", "argument --fps: must be above 0 and at most 240"),
    ("render {a}/dance.bvh -o {o}/x.gif --fps 1000", "argument --fps: must be above 0 and at most 240"),
    ("render {a}/dance.bvh -o {o}/x.gif --seconds 0", "argument --seconds: must be above 0"),
    ("render {a}/dance.bvh -o {o}/x.html -o {o}/x.txt", "-o {o}/x.txt: the file name must end in .gif, .mp4 or .html"),
    ("render {a}/dance.bvh -o {a}/folder", "-o {a}/folder: is a folder"),
    ("render {a}/dance.bvh --music {a}/missing.wav -o {o}/x.html", "--music {a}/missing.wav: music file not found"),
    # evaluate
    ("evaluate --generated {o}/missing --reference {a}/folder",
     "--generated {o}/missing: folder of motion files not found"),
    ("evaluate --generated {a}/text.txt --reference {a}/folder", "--generated {a}/text.txt: is a file"),
    ("evaluate --generated {a}/folder --reference {a}/folder -o {a}/folder", "-o {a}/folder: is a folder"),
    ("evaluate --generated {a}/folder --reference {a}/folder --plots {a}/text.txt", "--plots {a}/text.txt: is a file"),
    ("evaluate --generated {a}/folder --reference {a}/folder --fps 0", "argument --fps: must be above 0"),
    ("evaluate --generated {a}/folder --reference {a}/folder --plot-clips -1", "argument --plot-clips"),
    ("evaluate --generated {a}/folder --reference {a}/folder --metrics nosuch", "unknown metric 'nosuch'"),
    # recipe
    ("recipe validate {a}/empty.yaml", "{a}/empty.yaml: recipe file is empty"),
    ("recipe validate no-such-recipe", "bundled: "),
    ("recipe show {a}/folder", "{a}/folder: is a folder, not a recipe file"),
    ("recipe validate core-synthetic --set nokey", "--set 'nokey': expected FIELD.PATH=VALUE"),
    ("recipe schema -o {a}/folder", "-o {a}/folder: is a folder"),
    ("recipe schema -o {a}/text.txt/schema.json", "-o {a}/text.txt/schema.json: {a}/text.txt is a file"),
    ("recipe list --bogus", "unrecognized arguments: --bogus"),
    ("recipe", "the following arguments are required: ACTION"),
    # plugins, plugin new
    ("plugins --jsn", "unrecognized arguments: --jsn"),
    ("plugin new Bad_Name --kind head --out {o}", "plugin name 'Bad_Name'"),
    ("plugin new mine --kind vocoder --out {o}", "argument --kind: invalid choice: 'vocoder'"),
    ("plugin new mine --kind head --out {a}/text.txt", "--out {a}/text.txt: is a file, not a folder"),
    ("plugin new core --kind head --out {o}", "dance-core is one of dance's own packages"),
]

USAGE = re.compile(r"^dance(?: [\w-]+)*: error: ")


def split(line: str) -> list[str]:
    """A command line from the table as argv (single quotes group words)."""
    return [a.strip("'") for a in re.findall(r"'[^']*'|\S+", line)]


def snapshot(*folders: Path) -> set[tuple[str, int]]:
    """Every file and folder under ``folders`` with its size: what a failed command must leave alone."""
    return {(str(p), p.stat().st_size if p.is_file() else -1) for f in folders for p in f.rglob("*")}


@pytest.fixture(scope="module")
def assets(tmp_path_factory) -> Path:
    """Inputs of the corpus: a 2-s song and its BVH dance, and the bad files."""
    from dance_core.formats.bvh import BvhFormat
    from dance_core.formats.wav import write_wav
    from dance_core.synth.synthetic_dance import make_clip

    a = tmp_path_factory.mktemp("assets")
    clip = make_clip(0, seed=3, seconds=2.0, bpm=(120.0, 120.0), rate=16000, fps=20.0)
    write_wav(a / "song.wav", clip.audio.samples, clip.audio.rate)
    BvhFormat().write_motion(clip.motion.skeleton_motion, a / "dance.bvh")
    (a / "empty.wav").write_bytes(b"")
    (a / "empty.yaml").write_text("")
    (a / "fake.mp3").write_text("this is a text file, not an MP3\n" * 4)
    (a / "text.txt").write_text("a plain file where a folder goes\n")
    (a / "folder").mkdir()
    (a / "folder" / "note.txt").write_text("not a motion file\n")
    return a


def _needs(argv: list[str]) -> str | None:
    """Why a case cannot run here (a plugin it needs is not installed), else None."""
    from dance_core.registry import get_registry

    registry = get_registry()
    if argv[0] == "features" and "mel" not in registry.names("feature"):
        return "dance-audio is not installed"
    if "default" in argv[:2] and "default" not in registry.names("recipe"):
        return "the bundled 'default' recipe (dance-flow) is not installed"
    return None


def run_main(argv: list[str]) -> int:
    """``main(argv)``'s exit code, usage errors (SystemExit) included."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


@pytest.mark.parametrize("line,expected", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_naming_the_argument_and_writes_nothing(line, expected, assets, tmp_path,
                                                                     monkeypatch, capsys):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)  # a default output (report.json...) would land here
    fill = {"a": str(assets), "o": str(work)}
    argv = split(line.format(**fill))
    reason = _needs(argv)
    if reason:
        pytest.skip(reason)
    before = snapshot(assets, work)
    code = run_main(argv)
    out, err = capsys.readouterr()
    assert code not in (0, None), out
    assert "Traceback" not in err
    errors = [ln for ln in err.splitlines() if USAGE.match(ln)]
    assert len(errors) == 1, err
    others = [ln for ln in err.splitlines() if ln.strip() and ln not in errors]
    assert all(ln.startswith("dance: warning:") for ln in others), err
    assert expected.format(**fill) in errors[0]
    assert snapshot(assets, work) == before  # nothing created, nothing changed


def test_the_corpus_is_large_and_listed_in_the_docs():
    assert len(CASES) >= 40 and len({c[0] for c in CASES}) == len(CASES)
    docs = Path(__file__).resolve().parents[3] / "docs" / "reliability.md"
    text = docs.read_text(encoding="utf-8")
    missing = [line for line, _ in CASES if f"`dance {line}`" not in text]
    assert not missing, f"docs/reliability.md lacks: {missing}"


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_output_folder_is_one_line(assets, tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        code = run_main(["synth", str(locked / "x.wav")])
        err = capsys.readouterr().err
        assert code == 1 and f"cannot write in {locked}" in err and len(err.strip().splitlines()) == 1
        assert not any(locked.iterdir())
    finally:
        locked.chmod(0o755)


def test_common_flags_work_after_the_subcommand_too(capsys, monkeypatch):
    from dance_core.cli import commands

    def boom(args):
        assert args.quiet is True
        raise ValueError("bad value")

    monkeypatch.setattr(commands, "recipe_list", boom)
    assert run_main(["recipe", "list", "-q"]) == 1
    with pytest.raises(ValueError):
        main(["recipe", "list", "-q", "--debug"])
    with pytest.raises(ValueError):
        main(["--debug", "-q", "recipe", "list"])
    capsys.readouterr()


@pytest.mark.parametrize(
    "exc,expected",
    [
        (PermissionError(13, "Permission denied", "/data/out.npz"), "dance: error: /data/out.npz: Permission denied"),
        (OSError(28, "No space left on device"), "dance: error: [Errno 28] No space left on device"),
        (ValueError("could not broadcast\n  shapes (3,) (4,)"), "dance: error: could not broadcast shapes (3,) (4,)"),
        (MemoryError(), "dance: error: out of memory"),
    ],
)
def test_catch_all_turns_remaining_errors_into_one_line(exc, expected, monkeypatch, capsys):
    from dance_core.cli import commands

    def fail(args):
        raise exc

    monkeypatch.setattr(commands, "plugins", fail)
    assert run_main(["plugins"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(expected) and len(err.strip().splitlines()) == 1 and "--debug" in err
    with pytest.raises(type(exc)):
        main(["plugins", "--debug"])


def test_help_shows_defaults_choices_and_examples(capsys):
    for argv, wanted in (
        (["synth", "--help"], ["(default: 22050)", "{flux,librosa,madmom,auto}", "examples:", "dance synth song.wav"]),
        (["compose", "--help"], ["(default: compose.samples)", "examples:", "--json"]),
        (["render", "--help"], ["(default: 480 480)", "examples:"]),
        (["train", "--help"], ["examples:", "--stop-at"]),
        (["recipe", "list", "--help"], ["--json", "examples:"]),
    ):
        with pytest.raises(SystemExit):
            main(argv)
        out = " ".join(capsys.readouterr().out.split())  # as one line: help wraps to the terminal
        assert all(w in out for w in wanted), (argv, out)


def test_recipe_errors_of_every_class_at_once(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nfps: -3\nmodel:\n  encoder: {plugin: window-mlp, nope: 2}\n  head: {plugin: flw}\n")
    assert run_main(["recipe", "validate", str(bad)]) == 1
    err = capsys.readouterr().err
    assert f"{bad}:2: fps:" in err  # a schema error
    assert f"{bad}:4: model.encoder.nope:" in err and f"{bad}:5: model.head.plugin: unknown head" in err  # components
    assert "Traceback" not in err


def test_recipe_list_json(capsys):
    assert main(["recipe", "list", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    found = {e["name"]: e for e in data}
    assert "core-synthetic" in found and Path(found["core-synthetic"]["path"]).is_file()


def test_compose_prints_files_then_a_summary_or_json(assets, tmp_path, capsys):
    if _needs(["compose", "default"]):
        pytest.skip("the bundled 'default' recipe (dance-flow) is not installed")
    song = str(assets / "song.wav")
    assert main(["compose", "default", "--music", song, "-o", str(tmp_path / "a"), "--format", "npz"]) == 0
    out, err = capsys.readouterr()
    assert out.split() == [str(tmp_path / "a" / "song.npz")]
    assert re.search(r"composed 1 song\(s\) x 1: 2\.0 s of dance, 1 file\(s\) in .*, \d+ frames/s", err)
    assert main(["compose", "default", "--music", song, "-o", str(tmp_path / "b"), "--format", "npz",
                 "--json", "-q"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["songs"] == [song] and summary["seconds"] == pytest.approx(2.0)
    assert summary["files"] == [str(tmp_path / "b" / "song.npz")] and summary["frames_per_second"] > 0


def test_render_reports_progress_per_frame(assets, tmp_path):
    pytest.importorskip("matplotlib")
    from dance_core.formats.bvh import BvhFormat
    from dance_core.render.video import write_gif

    motion = BvhFormat().read_motion(assets / "dance.bvh").crop(0, 5)
    seen = []
    n = write_gif(tmp_path / "d.gif", motion.positions(), motion.skeleton.parents, motion.skeleton.names,
                  motion.fps, width=64, height=64, progress=lambda done, total: seen.append((done, total)))
    assert n == 5 and seen == [(i, 5) for i in range(1, 6)]


def test_evaluate_json_prints_the_report(assets, tmp_path, capsys):
    from dance_core.formats.bvh import BvhFormat

    folder = tmp_path / "set"
    folder.mkdir()
    motion = BvhFormat().read_motion(assets / "dance.bvh")
    for name in ("a", "b"):
        BvhFormat().write_motion(motion, folder / f"{name}.bvh")
    argv = ["-q", "evaluate", "--generated", str(folder), "--reference", str(folder), "--metrics", "fid-k",
            "--no-plots", "-o", str(tmp_path / "r.json"), "--json"]
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads((tmp_path / "r.json").read_text()) and np.isfinite(printed["values"]["FID_k"])
