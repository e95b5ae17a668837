"""Helpers for testing dance plugins: register a plugin object for the duration of a block."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

from dance_core import registry
from dance_core.plugins import check_hooks, get_plugin_manager


@contextlib.contextmanager
def registered_plugin(plugin: Any, name: str) -> Iterator[registry.Registry]:
    """Register ``plugin`` on the process-wide manager as ``name``; yield the fresh registry; undo after.

    Strict inside the block: a broken plugin raises ``PluginError`` instead of being skipped. When the
    plugin is already installed (an author running pytest on an installed package), the installed copy
    is set aside for the block and put back after, so its components are not registered twice.
    """
    pm = get_plugin_manager()
    set_aside = [(n, p) for n, p in pm.list_name_plugin() if n == name or p is plugin]
    for other, _ in set_aside:
        pm.unregister(name=other)
    strict, pm.strict = pm.strict, True
    pm.register(plugin, name=name)
    registry.reset()
    try:
        check_hooks(pm)
        yield registry.get_registry()
    finally:
        if pm.has_plugin(name):
            pm.unregister(name=name)
        for other, p in set_aside:
            pm.register(p, name=other)
        pm.strict = strict
        registry.reset()
