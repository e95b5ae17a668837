"""Each package installs alone: its pyproject declares (directly or through its first-party
dependencies) every distribution that provides a component its bundled recipes name. And which
bundled recipes read madmom's non-commercial files is what README's Licences section says."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
PACKAGES = sorted(p.parent for p in (REPO / "packages").glob("*/pyproject.toml"))
RECIPES = sorted((REPO / "packages").glob("*/src/*/recipes/*.yaml"))
NON_COMMERCIAL_TRACKERS = ("madmom", "auto")


def _project(package: Path) -> dict:
    return tomllib.loads((package / "pyproject.toml").read_text())["project"]


def _requirement_name(spec: str) -> str:
    return re.split(r"[\s\[<>=!~;]", spec, maxsplit=1)[0].lower()


def _closure(dist: str, projects: dict[str, dict]) -> set[str]:
    """The distribution and every first-party distribution it requires, transitively (no extras)."""
    seen, todo = set(), [dist]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        todo += [r for r in map(_requirement_name, projects[name].get("dependencies", [])) if r in projects]
    return seen


def _recipe(path: Path) -> dict:
    """A bundled recipe with its ``extends:`` chain merged (bundled bases only)."""
    data = yaml.safe_load(path.read_text())
    base = data.pop("extends", None)
    if base is None:
        return data
    found = [p for p in RECIPES if p.stem == base] or [path.parent / base]
    assert found[0].is_file(), f"{path.name}: extends {base!r}, not a bundled recipe"
    merged = _recipe(found[0])
    merged.update(data)  # top-level sections are enough to know the components
    return merged


def components(recipe: dict) -> set[tuple[str, str]]:
    """(kind, registered name) of every component a recipe names."""
    found: set[tuple[str, str]] = set()
    for specs in (recipe.get("features") or {}).values():
        found |= {("feature", s["plugin"]) for s in specs}
    if recipe.get("motion"):
        found.add(("motion-representation", recipe["motion"]["plugin"]))
    model = recipe.get("model") or {}
    found |= {("conditioner", s["plugin"]) for s in (model.get("conditioners") or {}).values()}
    found |= {(kind, model[kind]["plugin"]) for kind in ("encoder", "head") if model.get(kind)}
    dataset = (recipe.get("data") or {}).get("dataset")
    if dataset:
        found.add(("dataset", dataset["plugin"]))
        if dataset.get("dance_to_tracker"):
            found.add(("feature", "beats"))
    training = recipe.get("training") or {}
    found.add(("schedule", (training.get("lr_schedule") or {"plugin": "constant"})["plugin"]))
    found |= {("schedule", s["plugin"]) for s in (training.get("schedules") or {}).values()}
    found |= {("motion-format", f) for f in (recipe.get("compose") or {}).get("formats", ["npz"])}
    return found


def reads_madmom_files(recipe: dict) -> bool:
    """Whether composing or training with the recipe reads madmom's network weights."""
    for specs in (recipe.get("features") or {}).values():
        for spec in specs:
            if spec["plugin"] == "madmom-downbeat":
                return True
            if spec["plugin"] == "beats" and spec.get("tracker") in NON_COMMERCIAL_TRACKERS:
                return True
    dataset = (recipe.get("data") or {}).get("dataset") or {}
    return dataset.get("dance_to_tracker") in NON_COMMERCIAL_TRACKERS


def test_every_package_and_recipe_is_found():
    assert {p.name for p in PACKAGES} >= {"dance-core", "dance-audio", "dance-flow", "dance-rnn", "dance-tokens"}
    assert len(RECIPES) >= 9


@pytest.mark.parametrize("path", RECIPES, ids=lambda p: f"{p.parts[-5]}/{p.name}")
def test_a_package_declares_what_its_bundled_recipes_need(path):
    from dance_core.registry import get_registry

    registry = get_registry()
    projects = {_project(p)["name"]: _project(p) for p in PACKAGES}
    owner = _project(path.parents[3])["name"]
    installed_with_it = _closure(owner, projects)
    for kind, name in sorted(components(_recipe(path))):
        provider = registry.get(kind, name).distribution
        assert provider in installed_with_it, (
            f"{path.name} uses {kind} {name!r} from {provider}, which {owner}'s pyproject does not require"
        )


def test_the_default_recipe_reads_no_non_commercial_file():
    from dance_audio.configs import BeatsConfig

    assert BeatsConfig().tracker not in NON_COMMERCIAL_TRACKERS
    default = next(p for p in RECIPES if p.name == "transflower-small.yaml")  # `default` (dance-flow's plugin)
    assert not reads_madmom_files(_recipe(default))
    for path in RECIPES:  # core's and the small ones: the recipes meant to be run as they are
        if path.parts[-5] == "dance-core" or path.stem.endswith("-small"):
            assert not reads_madmom_files(_recipe(path)), path.name


def test_readme_lists_the_bundled_recipes_that_read_madmom_files():
    readme = (REPO / "README.md").read_text()
    section = readme.split("\n## Licences\n", 1)[1].split("\n## ", 1)[0]
    line = next(x for x in section.splitlines() if "recipes that read madmom's files" in x)
    listed = set(re.findall(r"`([a-z0-9-]+)`", line.split("recipes that read madmom's files", 1)[1]))
    assert listed == {p.stem for p in RECIPES if reads_madmom_files(_recipe(p))}
