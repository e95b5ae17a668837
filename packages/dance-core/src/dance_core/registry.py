"""The registry: every component by kind, and the one API to look up, validate, build and select them.

Each entry knows its plugin, distribution, config model, builder and capabilities (the ``info``
keywords its kind accepts, validated at registration). ``Registry.create`` validates options with the
entry's config, builds it with the kind's typed context and checks the result against the kind's
protocol (``dance_core.contracts``), all read from the kind's row in ``dance_core.kinds``;
``for_suffix`` picks the reader of a file by suffix and priority. Every caller in core and the
first-party plugins uses these.
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import pluggy
from pydantic import BaseModel, ValidationError

from dance_core import kinds
from dance_core.contexts import as_kwargs
from dance_core.contracts import check_component, check_config_type
from dance_core.errors import PluginError
from dance_core.plugins import get_plugin_manager, plugin_distribution, plugin_failure

#: component kind -> the hook that registers it (a view of ``dance_core.kinds.KINDS``)
KINDS: dict[str, str] = {row.name: row.hook for row in kinds.KINDS.values()}


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
    except BaseException as exc:  # a module that exits or raises on import: one line naming it
        raise PluginError(f"cannot import builder {target!r}: {plugin_failure(exc, f'builder {target!r}')}") from exc


def options_error(exc: ValidationError) -> str:
    """``field: message; field: message`` for a pydantic error on a component's options."""
    parts = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in err["loc"]) or "(options)"
        msg = "required option is missing" if err["type"] == "missing" else err["msg"].removeprefix("Value error, ")
        parts.append(f"{loc}: {msg}")
    return "; ".join(parts)


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
    info: dict[str, Any] = field(default_factory=dict)  # the kind's capabilities, validated, defaults included

    @property
    def label(self) -> str:
        """``head 'flow' (plugin 'flow')``, for messages."""
        return f"{self.kind} {self.name!r} (plugin {self.plugin!r})"

    @property
    def suffixes(self) -> tuple[str, ...]:
        """File suffixes this reader or format handles (lower case, with the dot)."""
        return tuple(s.lower() for s in self.info.get("suffixes", ()))

    @property
    def priority(self) -> int:
        """Preference among entries handling the same suffix (higher wins; core's are 0)."""
        return int(self.info.get("priority", 0))

    @property
    def readable(self) -> bool:
        """False for write-only formats (previews)."""
        return not self.info.get("write_only", False)

    def validate(self, options: Mapping[str, Any] | BaseModel | None = None) -> BaseModel | None:
        """The config for these options (defaults when ``None``); raises pydantic's ``ValidationError``."""
        if self.config is None:
            if options:
                raise PluginError(f"{self.label} takes no options (got {', '.join(dict(options))})")
            return None
        if isinstance(options, self.config):
            return options
        if isinstance(options, BaseModel):
            options = options.model_dump()
        return self.config.model_validate(dict(options or {}))

    def config_for(self, options: Mapping[str, Any] | BaseModel | None = None) -> BaseModel | None:
        """Like ``validate`` but a bad option is one ``PluginError`` line naming the component."""
        try:
            return self.validate(options)
        except ValidationError as exc:
            raise PluginError(f"{self.label}: {options_error(exc)}") from None

    def build(self, config: BaseModel | None = None, context: Any = None) -> Any:
        """Build the component from its validated config and the kind's context, then check its contract."""
        if config is None and self.config is not None:
            config = self.config()
        want = kinds.KINDS[self.kind].context
        if context is not None and not isinstance(context, want):
            raise TypeError(f"{self.label} is built with a {want.__name__}, not a {type(context).__name__}")
        built = resolve_target(self.target)(config, **as_kwargs(context))
        return check_component(self.kind, built, self.label)


class Registry:
    """All registered components, collected from the plugin manager's hooks.

    A plugin whose hook raises, that registers an invalid config or a name another plugin has, is
    skipped with a warning (an error when the manager is strict).
    """

    def __init__(self, pm: pluggy.PluginManager):
        self.pm = pm
        self._entries: dict[str, dict[str, Entry]] = {kind: {} for kind in KINDS}
        failed: dict[str, str] = {}
        for kind, hook_name in KINDS.items():
            for impl in getattr(pm.hook, hook_name).get_hookimpls():
                if impl.plugin_name in failed:
                    continue
                added: list[Entry] = []
                try:
                    impl.function(register=self._register_callback(kind, impl.plugin_name, added))
                except BaseException as exc:
                    for entry in added:
                        self._entries[kind].pop(entry.name, None)
                    why = str(exc) if isinstance(exc, PluginError) else plugin_failure(
                        exc, f"plugin {impl.plugin_name!r} in {hook_name}")
                    failed[impl.plugin_name] = f"failed in {hook_name}: {why}"
        for plugin, why in failed.items():
            for entries in self._entries.values():
                for name in [n for n, e in entries.items() if e.plugin == plugin]:
                    del entries[name]
            skip = getattr(pm, "skip", None)
            if skip is None or getattr(pm, "strict", True):
                raise PluginError(f"plugin {plugin!r} {why}")
            skip(plugin, why)

    def _register_callback(self, kind: str, plugin: str, added: list[Entry]):
        dist, version = plugin_distribution(self.pm, plugin)

        def register(
            name: str,
            config: type[BaseModel] | None,
            build: Callable[..., Any] | str,
            description: str = "",
            **info: Any,
        ) -> None:
            """Register one component of this hook's kind (see docs/plugins.md)."""
            label = f"{kind} {name!r} (plugin {plugin!r})"
            check_config_type(config, label)
            if not (callable(build) or (isinstance(build, str) and (kind == "recipe" or ":" in build))):
                raise PluginError(f"{label}: build must be a callable or a 'module:function' string, not {build!r}")
            checked = capabilities(kind, info, label)
            existing = self._entries[kind].get(name)
            if existing is not None:
                raise PluginError(
                    f"two plugins register the {kind} {name!r}: {existing.plugin} "
                    f"({existing.distribution} {existing.version}) and {plugin} ({dist} {version})"
                )
            entry = Entry(kind, name, config, build, plugin, dist, version, description, checked)
            self._entries[kind][name] = entry
            added.append(entry)

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

    def create(
        self, kind: str, name: str, options: Mapping[str, Any] | BaseModel | None = None, context: Any = None
    ) -> Any:
        """Look up, validate ``options``, build with ``context`` and check: the one way to make a component."""
        entry = self.get(kind, name)
        return entry.build(entry.config_for(options), context)

    def suffixes(self, kind: str, readable: bool = True) -> dict[str, str]:
        """Suffix -> the entry chosen for it (highest priority, then name), for readers/formats."""
        out: dict[str, Entry] = {}
        for entry in self.entries(kind):
            if readable and not entry.readable:
                continue
            for suffix in entry.suffixes:
                if suffix not in out or entry.priority > out[suffix].priority:
                    out[suffix] = entry
        return {suffix: entry.name for suffix, entry in sorted(out.items())}

    def for_suffix(self, kind: str, suffix: str, readable: bool = True) -> Entry | None:
        """The entry that handles files of ``suffix`` (highest priority wins), or None."""
        name = self.suffixes(kind, readable).get(suffix.lower())
        return None if name is None else self.get(kind, name)

    def find(self, kind: str, name_or_suffix: str) -> Entry:
        """An entry by name (``bvh``) or by suffix (``.bvh``), for output formats given either way."""
        if name_or_suffix in self._entries[kind]:
            return self._entries[kind][name_or_suffix]
        suffix = name_or_suffix.lower()
        entry = self.for_suffix(kind, suffix if suffix.startswith(".") else f".{suffix}", readable=False)
        return entry if entry is not None else self.get(kind, name_or_suffix)


def capabilities(kind: str, info: Mapping[str, Any], label: str) -> dict[str, Any]:
    """The ``info`` keywords validated by the kind's capabilities model, or one ``PluginError`` line."""
    model = kinds.KINDS[kind].capabilities
    if model is None:
        if info:
            raise PluginError(f"{label}: {kind}s take no info keywords (got {', '.join(info)})")
        return {}
    try:
        return model.model_validate(dict(info)).model_dump()
    except ValidationError as exc:
        known = ", ".join(kinds.KINDS[kind].info_keywords())
        parts = [f"{'.'.join(map(str, e['loc']))}: " + (f"unknown {kind} keyword (known: {known})"
                 if e["type"] == "extra_forbidden" else e["msg"].removeprefix("Value error, "))
                 for e in exc.errors()]
        raise PluginError(f"{label}: {'; '.join(parts)}") from None


def unknown_message(kind: str, name: str, known: list[str]) -> str:
    """``unknown head 'flw' (did you mean 'flow'?); installed: flow, regression``."""
    close = difflib.get_close_matches(name, known, n=3, cutoff=0.5)
    hint = f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""
    installed = ", ".join(known) if known else "none"
    return f"unknown {kind} {name!r}{hint}; installed: {installed}"


@lru_cache(maxsize=1)
def get_registry() -> Registry:
    """The process-wide registry built from the process-wide plugin manager."""
    return Registry(get_plugin_manager())


def reset() -> None:
    """Forget the cached registry (after registering or unregistering a plugin)."""
    get_registry.cache_clear()
