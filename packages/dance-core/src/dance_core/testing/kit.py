"""The test kit's tools: a plugin registered for a block, assertions naming the component, builds
through the registry."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from typing import Any, NoReturn

from dance_core import registry
from dance_core.errors import DanceError, PluginError
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
    try:
        pm.add(plugin, name)
        registry.reset()
        check_hooks(pm)
        yield registry.get_registry()
    finally:
        if pm.has_plugin(name):
            pm.unregister(name=name)
        for other, p in set_aside:
            pm.register(p, name=other)
        pm.strict = strict
        registry.reset()


class Check:
    """Assertions whose messages start with the component's label."""

    def __init__(self, label: str):
        self.label = label

    def fail(self, what: str) -> NoReturn:
        """Raise ``AssertionError("<label>: <what>")``."""
        raise AssertionError(f"{self.label}: {what}")

    def that(self, condition: Any, what: str) -> None:
        """Fail with ``what`` unless ``condition`` holds."""
        if not condition:
            self.fail(what)

    @contextlib.contextmanager
    def calling(self, what: str) -> Iterator[None]:
        """Turn an exception raised inside the block into a failure naming the call."""
        try:
            yield
        except AssertionError:
            raise
        except Exception as exc:
            raise AssertionError(f"{self.label}: {what} raised {type(exc).__name__}: {exc}") from exc

    def count(self, value: Any, what: str, minimum: int = 0, optional: bool = False) -> None:
        """Fail unless ``value`` is an int ``>= minimum`` (or ``None`` when ``optional``)."""
        if optional and value is None:
            return
        ok = isinstance(value, int) and not isinstance(value, bool) and value >= minimum
        kind = "an int" + (" or None" if optional else "")
        self.that(ok, f"{what} must be {kind} >= {minimum}, got {value!r}")

    def tensor(self, value: Any, what: str, shape: tuple[int, ...]) -> None:
        """Fail unless ``value`` is a finite tensor of ``shape``."""
        import torch

        self.that(isinstance(value, torch.Tensor), f"{what} is a {type(value).__name__}, not a torch.Tensor")
        self.that(tuple(value.shape) == shape, f"{what} has shape {tuple(value.shape)}, expected {shape}")
        self.that(bool(torch.isfinite(value).all()), f"{what} has NaN or inf values")


def create(kind: str, name: str, options: Any, context: Any, reg: registry.Registry | None) -> tuple[Any, Check]:
    """Build through the registry; a failure to look up, validate or build is an ``AssertionError``."""
    reg = reg or registry.get_registry()
    try:
        entry = reg.get(kind, name)
    except PluginError as exc:
        raise AssertionError(str(exc)) from None
    check = Check(entry.label)
    try:
        return reg.create(kind, name, options, context), check
    except PluginError as exc:
        raise AssertionError(str(exc)) from exc
    except (DanceError, ValueError, TypeError) as exc:
        check.fail(f"cannot be built with options {dict(options or {})}: {type(exc).__name__}: {exc}")


def check_gradients(module: Any, check: Check, what: str) -> None:
    """At least one parameter got a gradient, and every gradient is finite."""
    import torch

    grads = [(n, p.grad) for n, p in module.named_parameters() if p.grad is not None]
    check.that(grads, f"{what} gave no parameter a gradient (are its layers registered as submodules?)")
    bad = [n for n, g in grads if not bool(torch.isfinite(g).all())]
    check.that(not bad, f"{what} gave non-finite gradients to {', '.join(bad[:3])}")


def check_losses(out: Any, check: Check, when: str) -> None:
    """A dict with a scalar ``"loss"`` tensor; every value a finite scalar."""
    import torch

    check.that(isinstance(out, Mapping), f"loss {when} returned a {type(out).__name__}, not a dict")
    check.that("loss" in out, f"loss {when} returned keys {sorted(out)}, without 'loss'")
    for key, value in out.items():
        check.that(
            isinstance(value, torch.Tensor) and value.numel() == 1,
            f"loss {when}: {key!r} must be a scalar tensor, got {getattr(value, 'shape', type(value).__name__)}",
        )
        if not bool(torch.isfinite(value).all()):
            check.fail(f"loss {when}: {key!r} is {float(value.detach())}")
