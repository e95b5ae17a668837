"""The plugin contract is enforced: protocols on build, config classes on register, broken plugins
skipped with a warning (an error when strict), ``extends:`` replacing a component whose plugin changes."""

import importlib.metadata

import pytest
import torch
from pydantic import BaseModel

from dance_core import ComponentConfig, hookimpl
from dance_core.cli.main import main
from dance_core.contexts import EncoderContext, HeadContext
from dance_core.errors import PluginError, RecipeError
from dance_core.plugins import make_plugin_manager
from dance_core.protocols import Window
from dance_core.recipe import load_recipe
from dance_core.registry import Registry
from dance_core.testing import registered_plugin

HEAD_CONTEXT = HeadContext(motion_dim=4, latent_dim=8, latent_tokens=1, window=Window(1, 1, 0))


class PlainHead:  # not an nn.Module: its weights would never reach a checkpoint
    frames = keep = history_frames = 1
    latent_tokens = None

    def loss(self, latent, target, history, ctx): ...
    def init_state(self, batch, generator): ...
    def step(self, latent, history, state, temperature, generator): ...
    def finish(self, motion, state): ...


class NoStepHead(torch.nn.Module):
    frames = keep = history_frames = 1
    latent_tokens = None

    def loss(self, latent, target, history, ctx): ...
    def init_state(self, batch, generator): ...
    def finish(self, motion, state): ...


class HeadPlugin:
    def __init__(self, cls):
        self.cls = cls

    @hookimpl
    def register_heads(self, register):
        register("odd", ComponentConfig, lambda config, **ctx: self.cls())


def test_a_head_that_is_not_a_module_fails_on_build_naming_the_plugin():
    message = r"head 'odd' \(plugin 'odd-heads'\).*not a torch.nn.Module"
    with registered_plugin(HeadPlugin(PlainHead), "odd-heads") as registry, pytest.raises(PluginError, match=message):
        registry.create("head", "odd", context=HEAD_CONTEXT)


def test_a_head_missing_a_protocol_method_names_it():
    message = r"lacks step \(the OutputHead protocol"
    with registered_plugin(HeadPlugin(NoStepHead), "odd-heads") as registry, pytest.raises(PluginError, match=message):
        registry.create("head", "odd", context=HEAD_CONTEXT)


def test_every_core_component_satisfies_its_contract():
    registry = Registry(make_plugin_manager(load_entry_points=False))
    for kind in ("feature", "audio-reader", "motion-format", "motion-representation", "metric", "schedule"):
        for entry in registry.entries(kind):
            assert entry.build() is not None, entry.label
    enc = registry.create("encoder", "window-mlp", {"motion_past": 2, "cond_past": 2}, EncoderContext(4, {"m": 3}))
    head = registry.create("head", "regression", {}, HeadContext(4, enc.out_dim, enc.latent_tokens, enc.window))
    assert isinstance(head, torch.nn.Module)
    with pytest.raises(TypeError, match="HeadContext"):
        registry.get("head", "regression").build(None, EncoderContext(4))


class NotAConfig(BaseModel):
    size: int = 1


class BadConfigPlugin:
    @hookimpl
    def register_heads(self, register):
        register("odd", NotAConfig, "x:y")


def test_a_config_that_is_not_a_component_config_is_one_line():
    message = r"plugin 'bad-config'.*NotAConfig.*not a dance_core.ComponentConfig"
    with pytest.raises(PluginError, match=message), registered_plugin(BadConfigPlugin(), "bad-config"):
        pass


def test_bad_options_outside_a_recipe_name_the_component():
    registry = Registry(make_plugin_manager(load_entry_points=False))
    with pytest.raises(PluginError, match=r"schedule 'cosine' \(plugin 'dance-core.components'\): warmup"):
        registry.create("schedule", "cosine", {"warmup": "soon"})


class Misspelt:
    @hookimpl
    def register_head(self, register):  # should be register_heads
        register("never", None, "x:y")


class Raises:
    @hookimpl
    def register_heads(self, register):
        register("half", ComponentConfig, "x:y")
        raise RuntimeError("boom")


def test_broken_plugins_are_skipped_with_a_warning_unless_strict(capsys):
    pm = make_plugin_manager(load_entry_points=False, strict=False)
    pm.register(Misspelt(), name="misspelt")
    pm.register(Raises(), name="raises")
    from dance_core.plugins import check_hooks

    check_hooks(pm)
    registry = Registry(pm)
    err = capsys.readouterr().err
    assert "plugin 'misspelt'" in err and "did you mean 'register_heads'" in err
    assert "plugin 'raises'" in err and "boom" in err and "--strict" in err and "DANCE_LOAD_PLUGINS=''" in err
    assert "half" not in registry.names("head") and "regression" in registry.names("head")
    assert {b.name for b in pm.broken} == {"misspelt", "raises"}
    strict = make_plugin_manager(load_entry_points=False, strict=True)
    strict.register(Raises(), name="raises")
    with pytest.raises(PluginError, match="'raises' failed in register_heads: RuntimeError: boom"):
        Registry(strict)


class FakeEntryPoint:
    name, value, dist = "ghost", "ghost_plugin:nothing", None

    def load(self):
        raise ImportError("No module named 'ghost_plugin'")


class MisnamedArgument:
    @hookimpl
    def register_heads(self, reg):  # the spec's argument is ``register``
        reg("never", None, "x:y")


class MisnamedEntryPoint:
    name, value, dist = "misnamed", "misnamed_plugin:plugin", None

    def load(self):
        return MisnamedArgument()


def _installed(monkeypatch, entry_point):
    from dance_core import plugins, registry

    real = importlib.metadata.entry_points

    def fake(group=None, **kw):
        found = list(real(group=group, **kw))
        return found + [entry_point] if group == plugins.GROUP else found

    monkeypatch.setattr(plugins, "entry_points", fake)
    plugins.get_plugin_manager.cache_clear()
    registry.reset()
    yield
    plugins.get_plugin_manager.cache_clear()
    registry.reset()


@pytest.fixture
def ghost_installed(monkeypatch):
    yield from _installed(monkeypatch, FakeEntryPoint())


@pytest.fixture
def misnamed_installed(monkeypatch):
    yield from _installed(monkeypatch, MisnamedEntryPoint())


def test_a_plugin_that_cannot_import_does_not_stop_the_cli(ghost_installed, capsys, monkeypatch):
    monkeypatch.delenv("DANCE_STRICT_PLUGINS", raising=False)
    assert main(["plugins", "--json"]) == 0
    out, err = capsys.readouterr()
    assert "plugin 'ghost'" in err and "cannot import ghost_plugin:nothing" in err
    assert '"plugin": "ghost"' in out and '"regression"' in out


def test_strict_makes_a_broken_plugin_an_error(ghost_installed, capsys, monkeypatch):
    monkeypatch.setenv("DANCE_STRICT_PLUGINS", "0")  # main sets it to 1; restored after
    assert main(["--strict", "plugins"]) == 1
    assert "plugin 'ghost'" in capsys.readouterr().err


def test_a_hook_with_a_misnamed_argument_is_skipped_and_listed_broken(misnamed_installed, capsys, monkeypatch):
    monkeypatch.delenv("DANCE_STRICT_PLUGINS", raising=False)
    assert main(["plugins"]) == 0
    out, err = capsys.readouterr()
    line = "hook register_heads(reg) does not match the spec register_heads(register)"
    assert [w for w in err.splitlines() if "misnamed" in w] == [
        f"dance: warning: plugin 'misnamed' from misnamed is broken and was skipped: {line} "
        "(--strict stops on it; DANCE_LOAD_PLUGINS='' loads no plugin)"
    ]
    assert f"BROKEN\t\tmisnamed\tmisnamed\t\t{line}" in out.splitlines()
    assert "Traceback" not in err and "never" not in out


def test_strict_makes_a_misnamed_argument_an_error(misnamed_installed, capsys, monkeypatch):
    monkeypatch.setenv("DANCE_STRICT_PLUGINS", "0")
    assert main(["--strict", "plugins"]) == 1
    err = capsys.readouterr().err
    assert "plugin 'misnamed'" in err and "register_heads(reg)" in err and "Traceback" not in err


def test_the_test_kit_names_a_misnamed_argument():
    message = r"register_heads\(reg\) does not match"
    with pytest.raises(PluginError, match=message), registered_plugin(MisnamedArgument(), "misnamed"):
        pass


def test_load_plugins_naming_nothing_warns(monkeypatch, capsys):
    monkeypatch.setenv("DANCE_LOAD_PLUGINS", "flwo")
    pm = make_plugin_manager()
    assert "DANCE_LOAD_PLUGINS names 'flwo', which matches no installed plugin" in capsys.readouterr().err
    assert not pm.has_plugin("flow")


def test_extends_with_another_plugin_replaces_the_component(tmp_path):
    (tmp_path / "r.yaml").write_text("extends: core-synthetic\nmodel:\n  head: {plugin: regression, frames: 2}\n"
                                     "  encoder: {plugin: window-mlp, motion_past: 3, cond_past: 3}\n")
    merged = load_recipe(tmp_path / "r.yaml")
    assert merged.model.head.config.loss == "l1"  # same plugin: options merged
    assert merged.model.encoder.config.hidden == 256 and merged.model.encoder.config.motion_past == 3
    (tmp_path / "s.yaml").write_text("extends: core-synthetic\nmodel:\n  head: {plugin: other-head}\n")
    with pytest.raises(RecipeError) as err:
        load_recipe(tmp_path / "s.yaml")
    assert "unknown head 'other-head'" in str(err.value) and "loss" not in str(err.value)


def test_a_preview_whose_extra_is_missing_fails_when_built_before_any_work(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as if dance-core[plots] were not installed
    registry = Registry(make_plugin_manager(load_entry_points=False))
    with pytest.raises(PluginError, match=r"pip install 'dance-core\[plots\]'"):
        registry.create("motion-format", "gif")
    with pytest.raises(PluginError, match=r"dance-core\[render\]"):
        registry.create("motion-format", "mp4")
    assert registry.create("motion-format", "html") is not None
