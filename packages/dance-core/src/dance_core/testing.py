"""Helpers for testing dance plugins: register a plugin object for the duration of a block."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

from dance_core import registry
from dance_core.plugins import get_plugin_manager


@contextlib.contextmanager
def registered_plugin(plugin: Any, name: str) -> Iterator[registry.Registry]:
    """Register ``plugin`` on the process-wide manager; yield the fresh registry; undo after."""
    pm = get_plugin_manager()
    pm.register(plugin, name=name)
    registry.reset()
    try:
        from dance_core.plugins import check_hooks

        check_hooks(pm)
        yield registry.get_registry()
    finally:
        pm.unregister(name=name)
        registry.reset()
