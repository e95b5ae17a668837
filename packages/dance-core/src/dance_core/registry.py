"""Registries of components by kind; every entry knows its plugin, version, config and builder."""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import pluggy
from pydantic import BaseModel

from dance_core.errors import PluginError

#: component kind -> the hook that registers it
KINDS: dict[str, str] = {
    "conditioner": "register_conditioners",
    "encoder": "register_encoders",
    "head": "register_heads",
    "feature": "register_feature_extractors",
    "audio-reader": "register_audio_readers",
    "motion-format": "register_motion_formats",
    "motion-representation": "register_motion_representations",
    "dataset": "register_datasets",
    "metric": "register_metrics",
    "schedule": "register_schedules",
    "recipe": "register_recipes",
}


def resolve_target(target: Callable[..., Any] | str) -> Callable[..., Any]:
    """Import a ``"module:attr"`` builder lazily, or return a callable as it is."""
    if not isinstance(target, str):
        return target
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
        return getattr(module, attr)
    except (ImportError, AttributeError) as exc:
        raise PluginError(f"cannot import builder {target!r}: {exc}") from exc


@dataclass(frozen=True)
class Entry:
    """One registered component."""

    kind: str
    name: str
    config: type[BaseModel] | None
    target: Callable[..., Any] | str
    plugin: str
    distribution: str
    version: str
    description: str = ""
    info: dict[str, Any] = field(default_factory=dict)

    def build(self, config: BaseModel | None = None, **context: Any) -> Any:
        """Build the component from its validated config (and context such as input sizes)."""
        if config is None and self.config is not None:
            config = self.config()
        return resolve_target(self.target)(config, **context)


class Registry:
    """All registered components, collected from the plugin manager's hooks."""

    def __init__(self, pm: pluggy.PluginManager):
        from dance_core.plugins import plugin_distribution

        self._entries: dict[str, dict[str, Entry]] = {kind: {} for kind in KINDS}
        for kind, hook_name in KINDS.items():
            hook = getattr(pm.hook, hook_name)
            for impl in hook.get_hookimpls():
                dist, version = plugin_distribution(pm, impl.plugin_name)
                register = self._register_callback(kind, impl.plugin_name, dist, version)
                try:
                    impl.function(register=register)
                except PluginError:
                    raise
                except Exception as exc:
                    raise PluginError(
                        f"plugin {impl.plugin_name!r} failed in {hook_name}: {type(exc).__name__}: {exc}"
                    ) from exc

    def _register_callback(self, kind: str, plugin: str, dist: str, version: str):
        def register(
            name: str,
            config: type[BaseModel] | None,
            build: Callable[..., Any] | str,
            description: str = "",
            **info: Any,
        ) -> None:
            existing = self._entries[kind].get(name)
            if existing is not None:
                raise PluginError(
                    f"two plugins register the {kind} {name!r}: {existing.plugin} "
                    f"({existing.distribution} {existing.version}) and {plugin} ({dist} {version})"
                )
            self._entries[kind][name] = Entry(kind, name, config, build, plugin, dist, version, description, dict(info))

        return register

    def entries(self, kind: str) -> list[Entry]:
        """Every entry of one kind, sorted by name."""
        return sorted(self._entries[kind].values(), key=lambda e: e.name)

    def names(self, kind: str) -> list[str]:
        """The registered names of one kind."""
        return sorted(self._entries[kind])

    def get(self, kind: str, name: str) -> Entry:
        """One entry; an unknown name lists close matches and what is installed."""
        try:
            return self._entries[kind][name]
        except KeyError:
            raise PluginError(unknown_message(kind, name, self.names(kind))) from None


def unknown_message(kind: str, name: str, known: list[str]) -> str:
    """``unknown head 'flw' (did you mean 'flow'?); installed: flow, regression``."""
    close = difflib.get_close_matches(name, known, n=3, cutoff=0.5)
    hint = f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""
    installed = ", ".join(known) if known else "none"
    return f"unknown {kind} {name!r}{hint}; installed: {installed}"


@lru_cache(maxsize=1)
def get_registry() -> Registry:
    """The process-wide registry built from the process-wide plugin manager."""
    from dance_core.plugins import get_plugin_manager

    return Registry(get_plugin_manager())


def reset() -> None:
    """Forget the cached registry (after registering or unregistering a plugin)."""
    get_registry.cache_clear()
