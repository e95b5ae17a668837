"""One table per component kind: hooks, protocols, contexts and capabilities agree, and the ``info``
keywords a plugin registers are validated by its kind's capabilities model."""

import inspect

import pytest

from dance_core import ComponentConfig, hookimpl, hookspecs
from dance_core.errors import PluginError
from dance_core.kinds import KINDS
from dance_core.plugins import make_plugin_manager
from dance_core.registry import Registry
from dance_core.testing import registered_plugin


def _specs() -> dict[str, object]:
    return {name: fn for name, fn in vars(hookspecs).items() if name.startswith("register_") and callable(fn)}


def test_every_kind_has_its_hookspec_and_every_register_hook_a_kind():
    specs = _specs()
    assert set(specs) - {"register_commands"} == {kind.hook for kind in KINDS.values()}
    for kind in KINDS.values():
        spec = specs[kind.hook]
        assert list(inspect.signature(spec).parameters) == ["register"], kind.name
        assert spec.__doc__ == f"Register {kind.description}.", kind.name


def test_kinds_agree_with_the_registry_view_and_the_contracts():
    from dance_core import registry

    assert {name: kind.hook for name, kind in KINDS.items()} == registry.KINDS
    assert {name for name, kind in KINDS.items() if kind.weights} == {"conditioner", "encoder", "head"}
    assert all(kind.protocol is not None for name, kind in KINDS.items() if name != "recipe")


class InfoPlugin:
    def __init__(self, hook_kind: str, **info):
        self.hook_kind, self.info = hook_kind, info

    @hookimpl
    def register_motion_formats(self, register):
        if self.hook_kind == "motion-format":
            register("odd", ComponentConfig, "x:y", **self.info)

    @hookimpl
    def register_heads(self, register):
        if self.hook_kind == "head":
            register("odd", ComponentConfig, "x:y", **self.info)


@pytest.mark.parametrize(
    ("kind", "info", "message"),
    [
        ("motion-format", {"sufixes": (".odd",)},
         r"sufixes: unknown motion-format keyword \(known: suffixes, priority,"),
        ("motion-format", {"priority": "high"}, r"priority: Input should be a valid integer"),
        ("motion-format", {"write_only": "yes"}, r"write_only: Input should be a valid boolean"),
        ("motion-format", {"suffixes": ("odd",)}, r"suffixes: a suffix starts with a dot"),
        ("head", {"suffixes": (".odd",)}, r"heads take no info keywords \(got suffixes\)"),
    ],
)
def test_an_unknown_or_ill_typed_info_keyword_is_one_line_naming_plugin_and_component(kind, info, message):
    match = rf"{kind} 'odd' \(plugin 'odd-info'\): {message}"
    with pytest.raises(PluginError, match=match) as err, registered_plugin(InfoPlugin(kind, **info), "odd-info"):
        pass
    assert "\n" not in str(err.value)


def test_capabilities_are_typed_with_their_defaults():
    with registered_plugin(InfoPlugin("motion-format", suffixes=[".ODD"], priority=3), "odd-info") as registry:
        entry = registry.get("motion-format", "odd")
        assert entry.info == {"suffixes": (".odd",), "priority": 3, "write_only": False}
        assert registry.for_suffix("motion-format", ".odd") is entry
    core = Registry(make_plugin_manager(load_entry_points=False))
    assert core.get("feature", "energy").info == {"reads": ("audio",), "beats": False}
    assert core.get("head", "regression").info == {}
