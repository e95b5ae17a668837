"""Issue 28, untrusted input: what a hostile or unlucky input may never do (docs/reliability.md, "Threat
model"). Each class is a table of cases: no injection into the HTML preview or through string formatting,
nothing outside the named outputs touched (links, devices, pipes, a link as a lock), no run or song's
dances lost, no partial output set taken as complete, recipes read within limits."""

from __future__ import annotations

import ast
import html
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from dance_core.atomic import OutputSet, set_complete, target_of, write_text
from dance_core.checks import refuse_same_names
from dance_core.cli.main import main
from dance_core.errors import DanceError, DataError
from dance_core.render.html import fill_page, player_html, script_json, write_html

ROOT = Path(__file__).resolve().parents[3]

# --------------------------------------------------------------------------------------- the HTML preview

HOSTILE = [
    "<!--<script>",
    "</script><script>alert(1)</script>",
    "</SCRIPT >",
    "<script>alert(document.cookie)</script>",
    "]]><!--",
    "-->",
    "a & b &amp; c",
    "line\u2028separator\u2029paragraph",
    '"quoted" \'single\'',
    "\\u003c backslash",
    "__DATA__",
    "__AUDIO__ __TITLE__",
    "<img src=x onerror=alert(1)>",
    "\x00nul\x1fcontrol",
    "emoji \U0001f483 and \u00e9",
]

PARENTS = [-1, 0, 1]
QUATS = np.tile([1.0, 0.0, 0.0, 0.0], (4, 3, 1))  # four frames of the rest pose


def _positions(frames: int = 4) -> np.ndarray:
    pos = np.zeros((frames, 3, 3))
    pos[:, 1, 1], pos[:, 2, 1] = 1.0, 2.0
    pos[:, 0, 0] = np.linspace(0, 0.3, frames)
    return pos


def _script_data(page: str) -> dict:
    """The JSON block of a page, cut out as a browser's HTML parser would: up to the first ``</script``."""
    tag = '<script type="application/json" id="motion">'
    start = page.index(tag) + len(tag)
    end = page.lower().index("</script", start)
    return json.loads(page[start:end])


@pytest.mark.parametrize("text", HOSTILE)
def test_preview_title_and_joint_names_are_data_never_markup(text):
    names = ["root", text, "tip"]
    page = player_html(_positions(), PARENTS, names, 30.0, title=text)
    data = _script_data(page)
    assert data["title"] == text and data["names"] == names  # the block ends where it should, holding the data
    block = page[page.index('id="motion">'):page.index("</script>")]
    assert "<" not in block[len('id="motion">'):] and "\u2028" not in block and "\u2029" not in block
    shown = re.search(r"<title>(.*?)</title>", page, re.S).group(1)
    assert html.unescape(shown) == text and "<" not in shown
    assert page.count("<script") == 2 and page.count("</script>") == 2  # no script was added
    assert "__DATA__" not in page.replace(json.dumps(text), "") or text.count("__DATA__")  # placeholders filled once


@pytest.mark.parametrize("text", HOSTILE)
def test_script_json_round_trips_and_is_inert(text):
    blob = script_json({"s": text, "n": [text]})
    assert json.loads(blob) == {"s": text, "n": [text]}
    assert not set(blob) & set("<>&\u2028\u2029")


@pytest.mark.parametrize("fields", [{"A": "__B__", "B": "x"}, {"A": "__A__"}, {"A": "\\1 \\g<0>"}])
def test_placeholders_are_filled_in_one_pass(fields):
    assert fill_page("[__A__|__B__]", fields) == f"[{fields['A']}|{fields.get('B', '__B__')}]"


@pytest.mark.parametrize("where, value", [((2, 1, 0), np.nan), ((0, 0, 2), np.inf), ((3, 2, 1), -np.inf)])
def test_a_non_finite_motion_is_refused_naming_the_file_and_nothing_is_written(tmp_path, where, value):
    pos = _positions()
    pos[where] = value
    out = tmp_path / "dance.html"
    with pytest.raises(DataError, match=rf"^{re.escape(str(out))}: cannot preview a motion that holds "
                                        rf"(NaN|inf) at frame {where[0]}, joint"):
        write_html(out, pos, PARENTS, ["a", "b", "c"], 30.0)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["song.html", "my.song.html", "x" * 200 + ".html", "sp ace é.html"])
def test_a_preview_written_under_a_temporary_name_is_titled_by_its_output(tmp_path, name):
    from dance_core.motion.motion import Motion
    from dance_core.motion.skeleton import Skeleton
    from dance_core.render.preview import render

    skeleton = Skeleton(["a", "b", "c"], PARENTS, np.array([[0, 0, 0], [0, 1, 0], [0, 1, 0]], float))
    motion = Motion(skeleton, 30.0, np.zeros((4, 3)), QUATS)
    with OutputSet() as out:
        tmp = out.path(tmp_path / name)
        assert target_of(tmp) == tmp_path / name or len(name) > 160
        render(motion, tmp)
    page = (tmp_path / name).read_text(encoding="utf-8")
    title = re.search(r"<title>(.*?)</title>", page).group(1)
    assert ".dance-" not in title
    if len(name) <= 160:
        assert html.unescape(title) == Path(name).stem


# ---------------------------------------------------------------------------------- no format strings


def _format_calls(source: str) -> list[int]:
    """Lines of ``x.format(...)`` calls whose receiver is not a string literal (a template we wrote)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        call = isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
        if call and node.func.attr in ("format", "format_map") and not isinstance(node.func.value, ast.Constant):
            lines.append(node.lineno)
    return lines


def test_no_string_formatting_of_values_that_are_not_our_own_literals():
    found = []
    for path in sorted((ROOT / "packages").glob("*/src/**/*.py")):
        found += [f"{path.relative_to(ROOT)}:{n}" for n in _format_calls(path.read_text(encoding="utf-8"))]
    assert found == []


@pytest.mark.parametrize("template", ["runs/{name.__class__.__mro__}", "runs/{0}", "runs/{x}", "runs/{name!r}",
                                      "runs/{{name}}", "runs/{name}/{name}", "runs/%s", "runs/{name:>{0}}"])
def test_training_output_fills_name_by_plain_replacement(tiny_recipe, template):
    from dance_core.train import run_dir_for

    recipe = tiny_recipe(f"training.output='{template}'")
    assert str(run_dir_for(recipe)) == template.replace("{name}", recipe.name)


# ------------------------------------------------------------------- links, devices, pipes: never replaced


def _specials(tmp_path: Path) -> dict[str, Path]:
    outside = tmp_path / "outside.txt"
    outside.write_text("keep me")
    link = tmp_path / "link.html"
    link.symlink_to(outside)
    dangling = tmp_path / "dangling.html"
    dangling.symlink_to(tmp_path / "nowhere.html")
    fifo = tmp_path / "pipe.html"
    os.mkfifo(fifo)
    return {"link": link, "dangling": dangling, "fifo": fifo, "device": Path("/dev/null")}


SPECIAL = ["link", "dangling", "fifo", "device"]
WHAT = {"link": "a symbolic link", "dangling": "a symbolic link", "fifo": "a FIFO", "device": "a character device"}


@pytest.mark.parametrize("kind", SPECIAL)
@pytest.mark.parametrize("writer", ["write_text", "output_set", "html"])
def test_writes_never_replace_or_follow_a_link_device_or_pipe(tmp_path, kind, writer):
    target = _specials(tmp_path)[kind]
    before = os.lstat(target)
    with pytest.raises(DataError, match=rf"^{re.escape(str(target))}: is {WHAT[kind]}"):
        if writer == "write_text":
            write_text(target, "new")
        elif writer == "output_set":
            with OutputSet() as out:
                out.path(tmp_path / "fine.npz").write_bytes(b"x")
                out.path(target).write_text("new")
        else:
            write_html(target, _positions(), PARENTS, ["a", "b", "c"], 30.0)
    after = os.lstat(target)
    assert (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)
    assert (tmp_path / "outside.txt").read_text() == "keep me"
    assert not (tmp_path / "nowhere.html").exists() and not (tmp_path / "fine.npz").exists()
    assert not [p for p in tmp_path.iterdir() if ".dance-" in p.name]


@pytest.mark.parametrize("kind", SPECIAL)
@pytest.mark.parametrize("command", [["recipe", "schema", "-o", "{t}"],
                                     ["render", "{bvh}", "-o", "{t}"]])
def test_cli_outputs_refuse_a_link_device_or_pipe_in_one_line(tmp_path, kind, command, capsys):
    from dance_core.formats.bvh import BvhFormat
    from dance_core.motion.motion import Motion
    from dance_core.motion.skeleton import Skeleton

    target = _specials(tmp_path)[kind]
    bvh = tmp_path / "d.bvh"
    skeleton = Skeleton(["a", "b", "c"], PARENTS, np.array([[0, 0, 0], [0, 1, 0], [0, 1, 0]], float))
    BvhFormat().write_motion(Motion(skeleton, 30.0, np.zeros((4, 3)), QUATS),
                             bvh)
    argv = [a.format(t=target, bvh=bvh) for a in command]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and f"{target}: is {WHAT[kind]}" in err, err
    assert (tmp_path / "outside.txt").read_text() == "keep me" and not (tmp_path / "nowhere.html").exists()


@pytest.mark.parametrize("kind", ["file", "dangling", "folder"])
def test_a_lock_that_is_a_link_is_left_alone_with_its_target(tmp_path, kind):
    from dance_core.train import LOCK_FILE, run_lock

    run = tmp_path / "run"
    run.mkdir()
    outside = tmp_path / "precious"
    if kind == "file":
        outside.write_text("precious data\n")
        old = 1_000_000_000
        os.utime(outside, (old, old))  # older than any grace period: a plain stale lock would be taken over
    elif kind == "folder":
        outside.mkdir()
    (run / LOCK_FILE).symlink_to(outside)
    with pytest.raises(DanceError, match=r"train\.lock: is a symbolic link, not a lock dance made"), run_lock(run):
        pass
    assert (run / LOCK_FILE).is_symlink()
    if kind == "file":
        assert outside.read_text() == "precious data\n"
    else:
        assert outside.exists() == (kind == "folder")


def test_a_run_log_that_is_a_link_is_never_appended_through(tmp_path):
    from dance_core.train.run_folder import RunFolder

    outside = tmp_path / "outside.jsonl"
    outside.write_text("mine\n")
    (tmp_path / "log.jsonl").symlink_to(outside)
    with pytest.raises(DataError, match="log.jsonl: is a symbolic link"):
        RunFolder(tmp_path).log({"step": 1})
    assert outside.read_text() == "mine\n"


# ---------------------------------------------------------------------------------------- nothing lost


@pytest.mark.parametrize("held", [["model.safetensors"], ["state.safetensors"], ["model.safetensors",
                                                                                   "state.safetensors"]])
def test_train_into_a_folder_holding_a_run_is_refused_without_overwrite(tmp_path, held, capsys):
    run = tmp_path / "run"
    run.mkdir()
    for name in held:
        (run / name).write_bytes(b"a finished run's " + name.encode())
    before = {p.name: p.read_bytes() for p in run.iterdir()}
    code = main(["train", "core-synthetic", "-o", str(run), "--set", "training.steps=2"])
    err = capsys.readouterr().err
    assert code == 1 and f"-o {run}: holds a training run already ({', '.join(held)})" in err and "--overwrite" in err
    assert {p.name: p.read_bytes() for p in run.iterdir()} == before


def test_train_overwrite_replaces_and_resume_with_overwrite_is_refused(tiny_recipe, tmp_path, capsys):
    from dance_core.train import train

    run = tmp_path / "run"
    run.mkdir()
    (run / "model.safetensors").write_bytes(b"old")
    with pytest.raises(DanceError, match="holds a training run already"):
        train(tiny_recipe("training.steps=2"), out=str(run), quiet=True)
    assert (run / "model.safetensors").read_bytes() == b"old"
    result = train(tiny_recipe("training.steps=2", "training.checkpoint_every=2"), out=str(run), quiet=True,
                   overwrite=True)
    assert result.steps == 2 and (run / "model.safetensors").read_bytes() != b"old"
    assert main(["train", "core-synthetic", "-o", str(run), "--resume", "--overwrite"]) == 1
    assert "give one" in capsys.readouterr().err


@pytest.mark.parametrize("paths", [
    ["a/song.wav", "b/song.wav"], ["song.wav", "x/song.mp3"], ["a/s.wav", "b/t.wav", "c/s.flac"],
    ["song.tar.gz", "song.tar.bz2"], ["./s.wav", "s.wav"],
])
def test_two_inputs_with_one_output_name_are_refused_before_any_work(paths):
    with pytest.raises(DanceError, match=r"has the same name; their dances would overwrite each other"):
        refuse_same_names(paths, "--music")


def test_inputs_with_distinct_output_names_pass():
    refuse_same_names(["a/song.wav", "b/song2.wav", "Song.wav", "song-0.wav"], "--music")


def test_compose_refuses_two_songs_with_one_name_before_loading_anything(tmp_path, capsys):
    from dance_core.formats.wav import write_wav

    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        write_wav(tmp_path / sub / "song.wav", np.zeros(8000, np.float32), 8000)
    code = main(["compose", "core-synthetic", "--checkpoint", str(tmp_path / "none.safetensors"), "--music",
                 str(tmp_path / "a" / "song.wav"), str(tmp_path / "b" / "song.wav"), "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 1 and "has the same name" in err and not (tmp_path / "out").exists()


@pytest.mark.parametrize("fail_at", [0, 1, 2])
def test_a_set_whose_commit_is_cut_short_is_never_taken_as_complete(tmp_path, monkeypatch, fail_at):
    import dance_core.atomic as A

    targets = [tmp_path / n for n in ("s.bvh", "s.html", "s.npz")]
    manifest = tmp_path / ".s.outputs.json"
    with OutputSet(manifest) as out:
        for t in targets:
            out.path(t).write_text("old " + t.name)
    assert set_complete(manifest, targets)
    real, calls = A._publish, []

    def flaky(tmp, path, mode):
        calls.append(path)
        if len(calls) > fail_at:
            raise OSError(5, "Input/output error", str(path))
        real(tmp, path, mode)

    monkeypatch.setattr(A, "_publish", flaky)
    with pytest.raises(OSError), OutputSet(manifest) as out:  # --overwrite of the set, a rename fails
        for t in targets:
            out.path(t).write_text("new, longer " + t.name)
    monkeypatch.setattr(A, "_publish", real)
    assert not set_complete(manifest, targets)  # a mixed set (new BVH, old HTML) is redone, never skipped
    assert not [p for p in tmp_path.iterdir() if ".dance-" in p.name]


@pytest.mark.parametrize("mangle", ["missing", "not json", "wrong names", "bad size", "a link", "a folder"])
def test_a_damaged_manifest_means_an_incomplete_set(tmp_path, mangle):
    targets = [tmp_path / "s.bvh"]
    manifest = tmp_path / ".s.outputs.json"
    with OutputSet(manifest) as out:
        out.path(targets[0]).write_text("dance")
    assert set_complete(manifest, targets)
    if mangle == "missing":
        manifest.unlink()
    elif mangle == "not json":
        manifest.write_text("{")
    elif mangle == "wrong names":
        manifest.write_text(json.dumps({"files": [{"name": "t.bvh", "size": 5}]}))
    elif mangle == "bad size":
        manifest.write_text(json.dumps({"files": [{"name": "s.bvh", "size": "five"}]}))
    elif mangle == "a link":
        real = tmp_path / "real.json"
        manifest.rename(real)
        manifest.symlink_to(real)
    else:
        manifest.unlink()
        manifest.mkdir()
    assert not set_complete(manifest, targets)


# ---------------------------------------------------------------------------------------- empty values


@pytest.mark.parametrize("argv", [
    ["compose", "default", "--music", "x.wav", "-o", ""],
    ["compose", "default", "--music", "", "-o", "out"],
    ["compose", "default", "--music", "x.wav", "--checkpoint", " "],
    ["train", "core-synthetic", "-o", ""],
    ["train", ""],
    ["recipe", "schema", "-o", ""],
    ["recipe", "validate", ""],
    ["render", "x.bvh", "-o", ""],
    ["evaluate", "--generated", "", "--reference", "r"],
    ["retarget", "", "-o", "x.bvh"],
])
def test_an_empty_value_is_a_usage_error(argv, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "empty value" in err and err.count("\n") == 1


# ------------------------------------------------------------------------------------------- recipes


def _bomb(levels: int, width: int = 9) -> str:
    lines = ["name: bomb", "a0: &a0 [" + ", ".join(["x"] * width) + "]"]
    for k in range(1, levels):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


RECIPES = [  # (YAML text, what the one error line holds after "FILE:LINE: ")
    (_bomb(9), ":7: expands to more than 100000 values"),
    (_bomb(20, 2), "expands to more than 100000 values"),
    ("a: &a [*a]\n", ":1: an alias refers to the node that contains it"),
    ("a: &a {b: *a}\n", ":1: an alias refers to the node that contains it"),
    ("name: x\n" + "".join(f"k{i}: &k{i} 1\n" for i in range(101)) + "z: [" + ", ".join(f"*k{i}" for i in range(101))
     + "]\n", "more than 100 aliases"),
    ("a: " + "[" * 100 + "]" * 100 + "\n", ":1: nested deeper than 64 levels"),
    ("a: " + "{b: " * 80 + "1" + "}" * 80 + "\n", ":1: nested deeper than 64 levels"),
    ("".join("  " * i + f"k{i}:\n" for i in range(70)) + "  " * 70 + "v\n", "nested deeper than 64 levels"),
    ("a: " + "[" * 5000 + "]" * 5000 + "\n", "nested deeper than 64 levels"),
    ("name: x\nname: y\n", ":2: duplicate key 'name' (first at line 1)"),
    ("training:\n  steps: 1\n  lr: 2\n  steps: 3\n", ":4: duplicate key 'steps' (first at line 2)"),
    ("a: {b: 1, b: 2}\n", ":1: duplicate key 'b'"),
    ("- {x: 1, y: 2, x: 3}\n", ":1: duplicate key 'x'"),
    ("seed: " + "9" * 5000 + "\n", ":1: integer of 5000 characters is too large"),
    ("seed: -" + "1" * 30 + "\n", "integer of 31 characters is too large"),
    ("seed: 0x" + "f" * 40 + "\n", "too large"),
    ("lr: .inf\n", ":1: '.inf' is not a finite number"),
    ("lr: -.Inf\n", "'-.Inf' is not a finite number"),
    ("lr: .nan\n", "'.nan' is not a finite number"),
    ("lr: .NaN\n", "'.NaN' is not a finite number"),
    ("lr: 1e999\n", "'1e999' is not a finite number"),
    ("lr: -1.5e400\n", "not a finite number"),
    ("a:\n  b: [1, 2, .inf]\n", ":2: '.inf' is not a finite number"),
    ("a: [1, 2\n", "invalid YAML"),
    ("a: b: c\n", "invalid YAML"),
    ("a: !!python/object:os.system {}\n", "invalid YAML"),
    ("a: !!python/name:os.system\n", "invalid YAML"),
    ("a: *undefined\n", "invalid YAML"),
    ("\t- bad indent\n", "invalid YAML"),
    ("[1, 2]\n", ":1: a recipe must be a mapping of fields, not a list"),
    ("just text\n", "a recipe must be a mapping of fields, not a str"),
    ("x" * 1_000_001, "characters of YAML; at most 1000000 are read"),
]


@pytest.mark.parametrize("text, expected", RECIPES, ids=[f"recipe{k}" for k in range(len(RECIPES))])
def test_a_hostile_recipe_is_one_line_naming_the_file_and_line(tmp_path, capsys, text, expected):
    path = tmp_path / "r.yaml"
    path.write_text(text, encoding="utf-8")
    code = main(["recipe", "validate", str(path)])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"dance: error: {path}") and expected in err, err


SETS = [
    ("training.optimizer.lr=.inf", "--set training.optimizer.lr=.inf: '.inf' is not a finite number"),
    ("training.optimizer.lr=.nan", "'.nan' is not a finite number"),
    ("training.optimizer.lr=1e999", "'1e999' is not a finite number"),
    ("training.optimizer.lr=-.inf", "not a finite number"),
    ("training.steps=" + "9" * 5000, "integer of 5000 characters is too large"),
    ("training.steps=" + "9" * 25, "integer of 25 characters is too large"),
    ("data.dataset={a: 1, a: 2}", "duplicate key 'a'"),
    ("data.dataset=" + "[" * 70 + "]" * 70, "nested deeper than 64 levels"),
    ("data.dataset=&a [*a]", "recursive alias"),
    ("nokey", "--set 'nokey': expected FIELD.PATH=VALUE"),
    ("=1", "expected FIELD.PATH=VALUE"),
]


@pytest.mark.parametrize("assignment, expected", SETS, ids=[f"set{k}" for k in range(len(SETS))])
def test_a_hostile_set_is_one_line_naming_the_assignment(capsys, assignment, expected):
    code = main(["recipe", "validate", "core-synthetic", "--set", assignment])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and expected in err, err


def test_limits_leave_ordinary_yaml_alone():
    from dance_core.recipe.yaml_source import parse_text, parse_value

    text = "base: &b {lr: 1e-4, steps: 100}\nrun:\n  <<: *b\n  steps: 200\nbig: 18446744073709551615\nneg: -0.0\n"
    data = parse_text(text, "r.yaml").data
    assert data["run"] == {"lr": 1e-4, "steps": 200} and data["big"] == 2**64 - 1
    assert parse_value("[1, 2]") == [1, 2] and parse_value("1e-4") == 1e-4 and parse_value("a: b: c") == "a: b: c"


def test_bundled_recipes_pass_the_limits():
    from dance_core.recipe import load_recipe
    from dance_core.registry import get_registry

    for name in get_registry().names("recipe"):
        assert load_recipe(name).name  # "default" is transflower-small
