"""What a built component must be: its kind's protocol (and a ``torch.nn.Module`` for kinds holding
weights), both read from the kind's row in ``dance_core.kinds``.

Checked by the registry every time it builds a component, so a plugin that breaks its contract fails
at once with one line naming the plugin and what is missing, instead of training with its weights
silently left out of the checkpoint.
"""

from __future__ import annotations

import sys
from typing import Any

from pydantic import BaseModel

from dance_core.config import ComponentConfig
from dance_core.errors import PluginError
from dance_core.kinds import KINDS

_IGNORED = {"__init__", "__class_getitem__", "__init_subclass__", "__subclasshook__", "__parameters__"}


def protocol_members(protocol: type) -> list[str]:
    """Attribute and method names a protocol declares (``__call__`` included), in declaration order."""
    names: list[str] = []
    for base in reversed(protocol.__mro__):
        if base in (object,) or not getattr(base, "_is_protocol", False) or base.__name__ == "Protocol":
            continue
        for name in [*getattr(base, "__annotations__", {}), *vars(base)]:
            if name in _IGNORED or name in names:
                continue
            if name.startswith("_") and name != "__call__":
                continue
            names.append(name)
    return names


def missing_members(obj: Any, protocol: type) -> list[str]:
    """The protocol members ``obj`` lacks (methods must be callable)."""
    missing = []
    for name in protocol_members(protocol):
        if name == "__call__":
            if not callable(obj):
                missing.append("__call__")
            continue
        value = getattr(obj, name, _MISSING)
        if value is _MISSING:
            missing.append(name)
        elif callable(getattr(protocol, name, None)) and not callable(value):
            missing.append(f"{name}()")
    return missing


_MISSING = object()


def check_component(kind: str, obj: Any, label: str) -> Any:
    """``obj`` if it satisfies ``kind``'s contract, else a ``PluginError`` naming ``label`` and the gap.

    ``label`` names the component, e.g. ``"head 'flow' (plugin 'flow')"``.
    """
    if obj is None:
        raise PluginError(f"{label}: its builder returned None")
    row = KINDS[kind]
    if row.weights:
        torch = sys.modules.get("torch")
        if torch is None or not isinstance(obj, torch.nn.Module):
            raise PluginError(
                f"{label}: built a {type(obj).__name__}, which is not a torch.nn.Module "
                "(its weights would be left out of checkpoints)"
            )
    protocol = row.protocol
    if protocol is not None:
        missing = missing_members(obj, protocol)
        if missing:
            raise PluginError(
                f"{label}: built a {type(obj).__name__} that lacks {', '.join(missing)} "
                f"(the {protocol.__name__} protocol, dance_core.protocols)"
            )
    return obj


def check_config_type(config: Any, label: str) -> None:
    """Fail unless a registered config is ``None`` or a ``ComponentConfig`` subclass."""
    if config is None:
        return
    if not (isinstance(config, type) and issubclass(config, BaseModel)):
        raise PluginError(f"{label}: config {config!r} is not a class (a dance_core.ComponentConfig subclass)")
    if not issubclass(config, ComponentConfig):
        raise PluginError(
            f"{label}: config {config.__name__} is a pydantic model but not a dance_core.ComponentConfig "
            "subclass (which forbids unknown options and freezes them)"
        )
