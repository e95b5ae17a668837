from importlib.metadata import entry_points

import pytest

from dance_core import ComponentConfig, hookimpl
from dance_core.errors import PluginError
from dance_core.plugins import DEFAULT_PLUGINS, make_plugin_manager
from dance_core.registry import Registry, unknown_message
from dance_core.testing import registered_plugin


def test_installed_entry_points_are_discovered():
    pm = make_plugin_manager()
    names = {pm.get_name(p) for p in pm.get_plugins()}
    assert {"dance-core.components", "dance-core.formats", "audio", "flow", "rnn", "tokens"} <= names
    dists = {dist for dist, _ in pm.dists.values()}
    assert {"dance-audio", "dance-flow", "dance-rnn", "dance-tokens"} <= dists


def test_load_plugins_env_limits_what_loads(monkeypatch):
    monkeypatch.setenv("DANCE_LOAD_PLUGINS", "flow,dance-rnn")
    names = {make_plugin_manager().get_name(p) for p in make_plugin_manager().get_plugins()}
    core = set(DEFAULT_PLUGINS)
    assert names == core | {"flow", "rnn"}
    monkeypatch.setenv("DANCE_LOAD_PLUGINS", "")
    pm = make_plugin_manager()
    assert {pm.get_name(p) for p in pm.get_plugins()} == core
    assert len(list(entry_points(group="dance"))) >= 4


def test_core_registers_its_defaults_through_the_hooks():
    registry = Registry(make_plugin_manager(load_entry_points=False))
    head = registry.get("head", "regression")
    assert (head.plugin, head.distribution) == ("dance-core.components", "dance-core")
    assert "energy" in registry.names("feature")
    assert ".wav" in registry.get("audio-reader", "wav").info["suffixes"]


class Misspelt:
    @hookimpl
    def register_head(self, register):  # should be register_heads
        pass


def test_misspelt_hook_fails_loudly():
    with pytest.raises(PluginError, match="register_head"), registered_plugin(Misspelt(), "misspelt"):
        pass


class Dup:
    @hookimpl
    def register_heads(self, register):
        register("regression", ComponentConfig, lambda c, **k: None)


def test_duplicate_names_name_both_plugins():
    with pytest.raises(PluginError) as err, registered_plugin(Dup(), "dup-plugin"):
        pass
    assert "dance-core" in str(err.value) and "dup-plugin" in str(err.value)
    assert "'regression'" in str(err.value)


def test_unknown_name_lists_close_matches_and_installed():
    msg = unknown_message("head", "regresion", ["flow", "regression"])
    assert "did you mean 'regression'" in msg and "installed: flow, regression" in msg


class Broken:
    @hookimpl
    def register_heads(self, register):
        raise RuntimeError("boom")


def test_plugin_failing_in_a_hook_is_named():
    with pytest.raises(PluginError, match="'broken'.*boom"), registered_plugin(Broken(), "broken"):
        pass
