"""``dance plugin new`` writes packages that pass dance's contract checks, train in their example
recipe, install, are discovered and pass their own generated tests."""

from __future__ import annotations

import importlib
import importlib.util
import os
import subprocess
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

from dance_core.cli import plugin_new
from dance_core.cli.main import main
from dance_core.errors import DanceError
from dance_core.testing import check_encoder, check_feature, check_head, check_trains, registered_plugin

SMALL = ["data.dataset.songs=4", "data.dataset.seconds=6", "training.batch_size=16"]


@pytest.fixture
def generated(tmp_path, monkeypatch):
    """``make(kind)``: run ``dance plugin new my<kind> --kind <kind>`` into tmp_path and import its
    entry module from ``src/``; the modules are forgotten afterwards."""
    names = []

    def make(kind: str):
        name = f"my{kind}"
        assert main(["plugin", "new", name, "--kind", kind, "--out", str(tmp_path)]) == 0
        monkeypatch.syspath_prepend(str(tmp_path / f"dance-{name}" / "src"))
        names.append(f"dance_{name}")
        return importlib.import_module(f"dance_{name}.plugin")

    yield make
    for module in [m for m in sys.modules if any(m == n or m.startswith(f"{n}.") for n in names)]:
        del sys.modules[module]


def test_the_package_layout(tmp_path, capsys):
    assert main(["plugin", "new", "my-head", "--kind", "head", "--out", str(tmp_path)]) == 0
    root = tmp_path / "dance-my-head"
    files = sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())
    assert files == [
        "README.md",
        "pyproject.toml",
        "src/dance_my_head/__init__.py",
        "src/dance_my_head/configs.py",
        "src/dance_my_head/head.py",
        "src/dance_my_head/plugin.py",
        "src/dance_my_head/recipes/my-head-example.yaml",
        "tests/test_my_head.py",
    ]
    pyproject = (root / "pyproject.toml").read_text()
    assert 'name = "dance-my-head"' in pyproject and 'version = "0.1.0"' in pyproject
    assert '"dance-core>=0.1,<0.2"' in pyproject and '"torch>=2.1"' in pyproject
    assert '[project.entry-points.dance]\nmy-head = "dance_my_head.plugin"' in pyproject
    assert "class MyHeadHead(nn.Module)" in (root / "src/dance_my_head/head.py").read_text()
    assert "extends: core-synthetic" in (root / "src/dance_my_head/recipes/my-head-example.yaml").read_text()
    assert "$" not in "".join(p.read_text() for p in root.rglob("*") if p.is_file())  # every field filled
    assert [p.name for p in tmp_path.iterdir()] == ["dance-my-head"]  # no staging folder left
    assert "pip install -e" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("MyHead", "use lowercase letters and digits"),
        ("my head", "use lowercase letters and digits"),
        ("1head", "use lowercase letters and digits"),
        ("my--head", "use lowercase letters and digits"),
        ("core", "dance-core is one of dance's own packages"),
        ("regression", "head 'regression' is already registered by plugin 'dance-core.components'"),
    ],
)
def test_a_bad_name_is_one_line(tmp_path, capsys, name, why):
    assert main(["plugin", "new", name, "--kind", "head", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert why in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_an_installed_plugins_name_is_refused(monkeypatch):
    installed = [EntryPoint("beatnet", "dance_beatnet.plugin", "dance")]
    monkeypatch.setattr(plugin_new, "entry_points", lambda group: installed if group == "dance" else [])
    with pytest.raises(DanceError, match="the installed plugin 'beatnet'"):
        plugin_new.check_name("beatnet", "metric")


def test_an_existing_folder_is_never_overwritten(tmp_path, capsys):
    (tmp_path / "dance-mine").mkdir()
    (tmp_path / "dance-mine" / "keep.txt").write_text("mine")
    assert main(["plugin", "new", "mine", "--kind", "feature", "--out", str(tmp_path)]) == 1
    assert "already exists; not overwriting it" in capsys.readouterr().err
    assert [p.name for p in (tmp_path / "dance-mine").iterdir()] == ["keep.txt"]


def test_a_failed_write_leaves_nothing(tmp_path, monkeypatch):
    real = Path.write_text
    calls = []

    def flaky(self, *args, **kwargs):
        calls.append(self)
        if len(calls) == 4:
            raise OSError("disk full")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", flaky)
    with pytest.raises(OSError, match="disk full"):
        plugin_new.new_plugin("mine", "encoder", tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_an_unknown_kind_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["plugin", "new", "mine", "--kind", "vocoder", "--out", str(tmp_path)])
    assert exit_.value.code == 2 and "invalid choice: 'vocoder'" in capsys.readouterr().err


def test_core_requirement_follows_the_minor_series():
    assert plugin_new.core_requirement("0.1.0") == "dance-core>=0.1,<0.2"
    assert plugin_new.core_requirement("0.3.2") == "dance-core>=0.3,<0.4"
    assert plugin_new.core_requirement("1.4.0") == "dance-core>=1.4,<2"


@pytest.mark.parametrize(
    ("kind", "check", "weights"),
    [("head", check_head, "head."), ("encoder", check_encoder, "encoder."), ("feature", check_feature, None)],
)
def test_a_generated_component_passes_the_checks_and_trains(generated, tmp_path, kind, check, weights):
    plugin = generated(kind)
    with registered_plugin(plugin, f"my{kind}") as registry:
        assert registry.get(kind, f"my{kind}").plugin == f"my{kind}"
        check(f"my{kind}")
        result = check_trains(f"my{kind}-example", tmp_path / "run", steps=10, overrides=SMALL, weights=weights)
    assert result.steps == 10


def test_a_generated_format_and_reader_load_and_take_a_recipes_options(generated, tmp_path):
    import numpy as np

    from dance_core.data.features import load_audio
    from dance_core.data.files import read_motion_file
    from dance_core.protocols import MotionData
    from dance_core.recipe import load_recipe
    from dance_core.testing import check_component

    fmt, reader = generated("format"), generated("reader")
    with registered_plugin(fmt, "myformat"), registered_plugin(reader, "myreader") as registry:
        assert registry.get("motion-format", "myformat").info["suffixes"] == (".csv",)
        check_component("motion-format", "myformat")
        check_component("audio-reader", "myreader")
        recipe = load_recipe("core-synthetic", ["formats.myformat.precision=2", "formats.myreader.rate=8000"])
        options = recipe.format_options
        options.build(registry.get("motion-format", "myformat")).write(
            MotionData(np.array([[0.123456, 1.0]], np.float32), 30.0, ["a", "b"]), str(tmp_path / "m.csv"))
        assert (tmp_path / "m.csv").read_text().splitlines()[2] == "0.12,1"
        np.testing.assert_allclose(read_motion_file(tmp_path / "m.csv", registry).values, [[0.12, 1.0]])
        (tmp_path / "song.pcm").write_bytes(np.zeros(16000, "<i2").tobytes())
        assert load_audio(tmp_path / "song.pcm", registry).rate == 22050  # its default
        assert load_audio(tmp_path / "song.pcm", registry, options).rate == 8000  # the recipe's


def test_generated_code_is_lint_clean(tmp_path):
    if importlib.util.find_spec("ruff") is None:
        pytest.skip("ruff is not installed")
    for kind in plugin_new.KINDS:
        plugin_new.new_plugin(f"my-{kind}", kind, tmp_path)
    rules = ["--select", "E,F,W,I,B,UP,SIM"]
    for root in tmp_path.iterdir():
        for part, extra in (("src", ["--extend-select", "D1", "--ignore", "D104,D105,D107"]), ("tests", [])):
            run = subprocess.run(
                [sys.executable, "-m", "ruff", "check", "--no-cache", *rules, *extra, part],
                cwd=root, capture_output=True, text=True,
            )
            assert run.returncode == 0, f"{root.name}/{part}:\n{run.stdout}{run.stderr}"


@pytest.mark.slow
def test_generated_packages_install_are_discovered_and_pass_their_own_tests(tmp_path):
    """Every kind: its generated tests run by pytest in a fresh process (the fixtures come from
    dance-core's pytest11 entry point). The head is installed first (a wheel built from its
    pyproject), so its discovery test runs too; the others are imported from src/."""
    for kind in plugin_new.KINDS:
        plugin_new.new_plugin(f"my{kind}", kind, tmp_path / "pkgs")
    site = tmp_path / "site"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--target", str(site),
         str(tmp_path / "pkgs" / "dance-myhead")],
        capture_output=True, text=True,
    )
    assert install.returncode == 0, install.stdout + install.stderr
    assert (site / "dance_myhead" / "recipes" / "myhead-example.yaml").is_file()  # package data shipped
    paths = [str(site)] + [str(tmp_path / "pkgs" / f"dance-my{k}" / "src") for k in plugin_new.KINDS if k != "head"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths), "OMP_NUM_THREADS": "1"}
    env.pop("DANCE_LOAD_PLUGINS", None)
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs",
         *(str(tmp_path / "pkgs" / f"dance-my{k}" / "tests") for k in plugin_new.KINDS)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    skipped = [line for line in run.stdout.splitlines() if line.startswith("SKIPPED")]
    assert len(skipped) == len(plugin_new.KINDS) - 1 and not any("myhead" in line for line in skipped), skipped
