"""pytest plugin of dance-core (entry point ``pytest11: dance``): fixtures for testing dance plugins.

Installed with dance-core, so any plugin's tests can use them without a conftest:

- ``dance_registry``: the process-wide registry, rebuilt fresh before the test and forgotten after.
- ``dance_plugin``: ``dance_plugin(plugin, name)`` registers a plugin object (a module or an object
  with hook implementations) for the rest of the test, strictly (a broken plugin raises), and returns
  the registry; an installed copy of the same plugin is set aside meanwhile.

Loading this module imports neither torch nor the registry; the fixtures import what they use.
``pytest -p no:dance`` turns the plugin off.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

import pytest

__all__ = ["dance_plugin", "dance_registry"]


@pytest.fixture
def dance_registry() -> Iterator[Any]:
    """The process-wide ``dance_core.registry.Registry``, rebuilt before the test and reset after it."""
    from dance_core import registry

    registry.reset()
    try:
        yield registry.get_registry()
    finally:
        registry.reset()


@pytest.fixture
def dance_plugin() -> Iterator[Callable[[Any, str], Any]]:
    """A function ``(plugin, name) -> registry`` registering a plugin object until the test ends."""
    from dance_core.testing import registered_plugin

    with contextlib.ExitStack() as stack:

        def register(plugin: Any, name: str) -> Any:
            """Register ``plugin`` as ``name`` for the rest of the test; return the fresh registry."""
            return stack.enter_context(registered_plugin(plugin, name))

        yield register
