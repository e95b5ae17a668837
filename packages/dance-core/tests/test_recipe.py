import json
import textwrap

import pytest

from dance_core import ComponentConfig, hookimpl
from dance_core.errors import RecipeError
from dance_core.recipe import load_recipe
from dance_core.recipe.jsonschema import recipe_json_schema
from dance_core.registry import get_registry
from dance_core.testing import registered_plugin

BASE = """\
name: t
fps: 20
features:
  music:
    - plugin: energy
model:
  conditioners:
    music: {plugin: mlp, dim: 8}
  encoder: {plugin: window-mlp, motion_past: 4, cond_past: 4, cond_future: 2}
  head: {plugin: regression}
data:
  dataset: {plugin: synthetic-beats, songs: 3, seconds: 4}
training:
  steps: 10
  optimizer: {lr: 1e-4}
"""


def write(tmp_path, text, name="r.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def error_of(path, overrides=()):
    with pytest.raises(RecipeError) as err:
        load_recipe(path, list(overrides))
    return str(err.value)


def test_valid_recipe_numbers_are_numbers(tmp_path):
    recipe = load_recipe(write(tmp_path, BASE))
    assert recipe.training.optimizer.lr == 1e-4
    assert recipe.model.encoder.config.motion_past == 4
    assert recipe.model.head.config.loss == "l1"


def test_unknown_option_names_file_line_and_path(tmp_path):
    path = write(tmp_path, BASE.replace("{plugin: regression}", "{plugin: regression, n_layer: 3}"))
    assert error_of(path) == f"{path}:10: model.head.n_layer: unknown field"


def test_bad_option_type(tmp_path):
    path = write(tmp_path, BASE.replace("dim: 8", "dim: big"))
    msg = error_of(path)
    assert msg.startswith(f"{path}:8: model.conditioners.music.dim: ")
    assert "integer" in msg and "\n" not in msg


def test_unknown_plugin_lists_close_matches(tmp_path):
    path = write(tmp_path, BASE.replace("{plugin: regression}", "{plugin: regresion}"))
    msg = error_of(path)
    assert msg.startswith(f"{path}:10: model.head.plugin: unknown head 'regresion'")
    assert "did you mean 'regression'" in msg and "installed:" in msg


def test_unknown_top_level_field_and_missing_field(tmp_path):
    path = write(tmp_path, BASE + "trainig: {steps: 3}\n")
    assert error_of(path) == f"{path}:16: trainig: unknown field (did you mean 'training'?)"
    path = write(tmp_path, BASE.replace("name: t\n", ""), "m.yaml")
    assert error_of(path) == f"{path}:1: name: required field is missing"


def test_yaml_syntax_error_has_line(tmp_path):
    path = write(tmp_path, BASE.replace("steps: 10", "steps: [10"))
    msg = error_of(path)
    assert msg.startswith(f"{path}:") and "invalid YAML" in msg


def test_missing_file(tmp_path):
    assert "recipe file not found" in error_of(tmp_path / "nope.yaml")


def test_extends_and_set(tmp_path):
    write(tmp_path, BASE, "base.yaml")
    child = write(tmp_path, "extends: base.yaml\nname: child\ntraining: {steps: 5}\n", "child.yaml")
    recipe = load_recipe(child, ["training.optimizer.lr=3e-3", "features.music.0.n_fft=1024"])
    assert recipe.name == "child"
    assert recipe.training.steps == 5 and recipe.training.batch_size == 32
    assert recipe.training.optimizer.lr == 3e-3
    assert recipe.features["music"][0].config.n_fft == 1024
    assert recipe.model.encoder.config.cond_future == 2  # inherited


def test_errors_point_into_the_base_file_or_the_override(tmp_path):
    base = write(tmp_path, BASE.replace("dim: 8", "dim: -1"), "base.yaml")
    child = write(tmp_path, "extends: base.yaml\nname: child\n", "child.yaml")
    assert error_of(child).startswith(f"{base}:8: model.conditioners.music.dim:")
    msg = error_of(write(tmp_path, BASE), ["training.steps=zero"])
    assert msg.startswith("--set training.steps=zero: training.steps:")


def test_extends_cycle_and_bad_set(tmp_path):
    a = write(tmp_path, "extends: b.yaml\nname: a\n", "a.yaml")
    write(tmp_path, "extends: a.yaml\nname: b\n", "b.yaml")
    assert "cycle" in error_of(a)
    assert "expected FIELD.PATH=VALUE" in error_of(write(tmp_path, BASE), ["training.steps"])


def test_several_errors_one_line_each(tmp_path):
    path = write(tmp_path, BASE.replace("dim: 8", "dim: 0").replace("motion_past: 4", "motion_past: x"))
    lines = error_of(path).splitlines()
    assert len(lines) == 2 and all(line.startswith(f"{path}:") for line in lines)


class Heads:
    """A third-party head registered from a test, used by a recipe."""

    @hookimpl
    def register_heads(self, register):
        class MeanConfig(ComponentConfig):
            scale: float = 1.0

        def build(config, *, motion_dim, latent_dim, **_):
            from dance_core.components.configs import RegressionHeadConfig
            from dance_core.components.modules import RegressionHead

            head = RegressionHead(RegressionHeadConfig(loss="l2"), motion_dim, latent_dim, None)
            head.scale = config.scale
            return head

        register("test-l2", MeanConfig, build, "a head from a test plugin")


def test_plugin_registered_in_a_test_is_usable_from_a_recipe(tmp_path):
    from dance_core.train import train

    path = write(tmp_path, BASE.replace("{plugin: regression}", "{plugin: test-l2, scale: 2.5}"))
    with registered_plugin(Heads(), "test-heads") as registry:
        entry = registry.get("head", "test-l2")
        assert entry.plugin == "test-heads" and entry.version == "unpackaged"
        recipe = load_recipe(path)
        assert recipe.model.head.config.scale == 2.5
        result = train(recipe, out=str(tmp_path / "run"), quiet=True)
        assert result.checkpoint.exists()
    assert "test-l2" not in get_registry().names("head")


def test_json_schema_spells_out_plugin_options():
    schema = recipe_json_schema(get_registry())
    heads = schema["$defs"]["head-component"]["oneOf"]
    regression = next(h for h in heads if h["properties"]["plugin"]["const"] == "regression")
    assert set(regression["properties"]["loss"]["enum"]) == {"l1", "l2"}
    assert schema["$defs"]["ModelSpec"]["properties"]["head"]["$ref"] == "#/$defs/head-component"
    json.dumps(schema)
