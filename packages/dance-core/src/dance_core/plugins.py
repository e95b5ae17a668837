"""The plugin manager: core's defaults, entry points of the group ``dance``, and a hook check."""

from __future__ import annotations

import os
from functools import lru_cache
from importlib.metadata import entry_points

import pluggy

from dance_core import hookspecs
from dance_core.errors import PluginError

GROUP = "dance"
CORE_PLUGIN = "dance-core"
ENV_ALLOW = "DANCE_LOAD_PLUGINS"


def _allowed_names() -> set[str] | None:
    """Entry-point or distribution names allowed by ``DANCE_LOAD_PLUGINS`` (None: all)."""
    raw = os.environ.get(ENV_ALLOW)
    if raw is None:
        return None
    return {part.strip() for part in raw.split(",") if part.strip()}


def _load_entry_points(pm: pluggy.PluginManager) -> None:
    """Load every allowed entry point of the group, naming the plugin when one fails."""
    allowed = _allowed_names()
    if allowed is not None:
        for ep in entry_points(group=GROUP):
            dist = ep.dist.name if ep.dist is not None else ""
            if ep.name not in allowed and dist not in allowed:
                pm.set_blocked(ep.name)
    try:
        pm.load_setuptools_entrypoints(GROUP)
    except Exception as exc:
        for ep in entry_points(group=GROUP):
            if pm.is_blocked(ep.name) or pm.has_plugin(ep.name):
                continue
            dist = ep.dist.name if ep.dist is not None else "?"
            raise PluginError(
                f"plugin {ep.name!r} from {dist} failed to load ({ep.value}): {type(exc).__name__}: {exc}"
            ) from exc
        raise PluginError(f"loading plugins failed: {type(exc).__name__}: {exc}") from exc


def check_hooks(pm: pluggy.PluginManager) -> None:
    """Fail with a one-line error when a plugin implements a hook that does not exist."""
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        name = pm.get_name(exc.plugin) if exc.plugin is not None else "?"
        raise PluginError(f"plugin {name!r}: {exc}") from exc


def make_plugin_manager(load_entry_points: bool = True) -> pluggy.PluginManager:
    """Build a manager with core's defaults registered and (optionally) installed plugins."""
    from dance_core.components import plugin as core_plugin

    pm = pluggy.PluginManager(GROUP)
    pm.add_hookspecs(hookspecs)
    pm.register(core_plugin, name=CORE_PLUGIN)
    if load_entry_points:
        _load_entry_points(pm)
    check_hooks(pm)
    return pm


@lru_cache(maxsize=1)
def get_plugin_manager() -> pluggy.PluginManager:
    """The process-wide plugin manager, built on first use."""
    return make_plugin_manager()


def plugin_distribution(pm: pluggy.PluginManager, plugin_name: str) -> tuple[str, str]:
    """The (distribution, version) that provided a registered plugin."""
    if plugin_name == CORE_PLUGIN:
        from dance_core import __version__

        return CORE_PLUGIN, __version__
    plugin = pm.get_plugin(plugin_name)
    for registered, dist in pm.list_plugin_distinfo():
        if registered is plugin:
            return dist.metadata["name"], dist.version
    return plugin_name, "unpackaged"
