import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from dance_core.cli.main import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_help_imports_no_torch():
    code = "import sys; from dance_core.cli.main import build_parser; build_parser(); print('torch' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_version_and_bad_usage(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0 and capsys.readouterr().out.startswith("dance ")
    with pytest.raises(SystemExit) as exit_:
        main(["train"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and len(err.strip().splitlines()) == 1 and "required" in err


def test_user_error_is_one_line_without_traceback(capsys, tmp_path):
    bad = tmp_path / "r.yaml"
    bad.write_text("name: x\nmodel: {encoder: {plugin: window-mlp}, head: {plugin: flw}}\n")
    code, out, err = run(capsys, "recipe", "validate", str(bad))
    assert code == 1
    assert err.strip().splitlines() == [
        f"dance: error: {bad}:2: model.head.plugin: unknown head 'flw'" + err.split("'flw'", 1)[1].splitlines()[0]
    ]
    assert "Traceback" not in err
    from dance_core.errors import RecipeError

    with pytest.raises(RecipeError):  # --debug lets the exception (and its traceback) through
        main(["--debug", "recipe", "validate", str(bad)])


def test_plugins_lists_every_kind(capsys):
    code, out, _ = run(capsys, "plugins", "--json")
    data = json.loads(out)
    assert code == 0 and {"conditioner", "encoder", "head", "feature", "metric", "schedule"} <= set(data)
    assert any(e["name"] == "regression" and e["distribution"] == "dance-core" for e in data["head"])
    code, out, _ = run(capsys, "plugins")
    assert code == 0 and "regression" in out and "window-mlp" in out


def test_recipe_show_schema_list(capsys, tmp_path):
    code, out, _ = run(capsys, "recipe", "show", "core-synthetic", "--set", "training.steps=7")
    shown = yaml.safe_load(out)
    assert code == 0 and shown["training"]["steps"] == 7 and shown["model"]["head"]["plugin"] == "regression"
    code, _, _ = run(capsys, "recipe", "schema", "-o", str(tmp_path / "s.json"))
    assert code == 0 and "head-component" in json.loads((tmp_path / "s.json").read_text())["$defs"]
    code, out, _ = run(capsys, "recipe", "list")
    assert "core-synthetic" in out


def test_synth_train_compose_end_to_end(capsys, tmp_path):
    tiny = ["--set", "data.dataset.songs=3", "--set", "data.dataset.seconds=5", "--set", "training.steps=20"]
    assert run(capsys, "-q", "synth", str(tmp_path / "s.wav"), "--bpm", "100", "--seconds", "3")[0] == 0
    code, out, _ = run(capsys, "-q", "train", "core-synthetic", "-o", str(tmp_path / "run"), *tiny)
    assert code == 0 and out == "" and (tmp_path / "run" / "model.safetensors").is_file()  # -q: nothing printed
    code, out, _ = run(
        capsys,
        "compose",
        "core-synthetic",
        "--checkpoint",
        str(tmp_path / "run" / "model.safetensors"),
        "--music",
        str(tmp_path / "s.wav"),
        "-o",
        str(tmp_path / "out"),
        "--samples",
        "2",
        *tiny,
    )
    assert code == 0 and out.split() == [str(tmp_path / "out" / "s-0.npz"), str(tmp_path / "out" / "s-1.npz")]
    with np.load(tmp_path / "out" / "s-1.npz") as f:
        assert f["values"].shape == (60, 18)
    with pytest.raises(SystemExit) as exit_:  # a value out of range is a usage error naming its option
        main(["synth", str(tmp_path / "x.wav"), "--bpm", "5"])
    assert exit_.value.code == 2 and "--bpm" in capsys.readouterr().err
