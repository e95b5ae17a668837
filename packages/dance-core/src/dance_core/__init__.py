"""dance-core: plugin registry, recipes, protocols, training and composition loops."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from dance_core.config import ComponentConfig
from dance_core.errors import DanceError
from dance_core.hookspecs import hookimpl

try:
    __version__ = version("dance-core")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = ["ComponentConfig", "DanceError", "hookimpl", "__version__"]
