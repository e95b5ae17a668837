"""The plugin manager: core's default plugins, entry points of the group ``dance``, hook checks.

A third-party plugin that fails to import, implements a hook that does not exist or with arguments
its spec lacks, or fails while registering is skipped with a one-line warning (``dance plugins``
lists it as broken), so that one broken install does not stop every command; ``--strict`` (or
``DANCE_STRICT_PLUGINS=1``) makes it an error instead. ``DANCE_LOAD_PLUGINS=a,b`` loads only the named
plugins (``''``: none).
"""

from __future__ import annotations

import difflib
import importlib
import os
import sys
from dataclasses import dataclass
from functools import lru_cache
from importlib.metadata import EntryPoint, entry_points

import pluggy

from dance_core import hookspecs
from dance_core.errors import PluginError

GROUP = "dance"
CORE_PLUGIN = "dance-core"
ENV_ALLOW = "DANCE_LOAD_PLUGINS"
ENV_STRICT = "DANCE_STRICT_PLUGINS"

#: core's own defaults, each a plugin module registered through the same hooks as any other
DEFAULT_PLUGINS: dict[str, str] = {
    "dance-core.components": "dance_core.defaults.components",
    "dance-core.formats": "dance_core.defaults.formats",
    "dance-core.previews": "dance_core.defaults.previews",
    "dance-core.data": "dance_core.defaults.data",
    "dance-core.synth": "dance_core.defaults.synth",
    "dance-core.evaluation": "dance_core.defaults.evaluation",
    "dance-core.authoring": "dance_core.defaults.authoring",
    "dance-core.live": "dance_core.defaults.live",
}


@dataclass(frozen=True)
class BrokenPlugin:
    """A plugin that was skipped: its name, distribution and why."""

    name: str
    distribution: str
    reason: str


class DancePluginManager(pluggy.PluginManager):
    """A pluggy manager that also knows each plugin's distribution and the plugins it skipped."""

    def __init__(self, strict: bool = False):
        super().__init__(GROUP)
        self.strict = strict
        self.dists: dict[str, tuple[str, str]] = {}
        self.broken: list[BrokenPlugin] = []

    def skip(self, name: str, reason: str) -> None:
        """Unregister a broken plugin and remember why (an error instead when strict)."""
        dist = self.dists.get(name, (name, "?"))[0]
        if self.strict:
            raise PluginError(f"plugin {name!r} from {dist}: {reason}")
        if self.has_plugin(name):
            self.unregister(name=name)
        self.broken.append(BrokenPlugin(name, dist, reason))
        warn(
            f"plugin {name!r} from {dist} is broken and was skipped: {reason} "
            f"(--strict stops on it; {ENV_ALLOW}='' loads no plugin)"
        )

    def add(self, plugin: object, name: str) -> bool:
        """Register a plugin; one whose hooks pluggy rejects is skipped (an error when strict)."""
        try:
            self.register(plugin, name=name)
        except pluggy.PluginValidationError as exc:
            self.skip(name, spec_mismatch(self, plugin) or " ".join(str(exc).split()))
            return False
        return True


def plugin_failure(exc: BaseException, label: str) -> str:
    """What a plugin's code raised, in one line (``SystemExit(0): it tried to end dance``), for any exception,
    ``SystemExit`` included, so that dance carries on without it. An interrupt (Ctrl-C, SIGTERM, or a plugin
    raising ``KeyboardInterrupt``) is not carried past: it becomes a ``PluginError`` naming ``label`` that
    stops dance (exit 130, or 143 for SIGTERM)."""
    if isinstance(exc, KeyboardInterrupt):
        raise PluginError(f"{label}: interrupted while it ran ({type(exc).__name__}); dance stops") from exc
    if isinstance(exc, SystemExit):
        return f"SystemExit({exc.code!r}): it tried to end dance"
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def warn(message: str) -> None:
    """Print one warning line on stderr."""
    print(f"dance: warning: {message}", file=sys.stderr)


def strict_from_env() -> bool:
    """True when ``DANCE_STRICT_PLUGINS`` asks broken plugins to be errors."""
    return os.environ.get(ENV_STRICT, "").strip().lower() not in ("", "0", "false", "no")


def _allowed_names() -> set[str] | None:
    """Entry-point or distribution names allowed by ``DANCE_LOAD_PLUGINS`` (None: all)."""
    raw = os.environ.get(ENV_ALLOW)
    if raw is None:
        return None
    return {part.strip() for part in raw.split(",") if part.strip()}


def _dist_of(ep: EntryPoint) -> tuple[str, str]:
    dist = ep.dist
    return (dist.metadata["name"], dist.version) if dist is not None else (ep.name, "unpackaged")


def _load_entry_points(pm: DancePluginManager) -> None:
    """Import and register every allowed entry point of the group; skip (or fail on) broken ones."""
    allowed = _allowed_names()
    eps = sorted(entry_points(group=GROUP), key=lambda ep: ep.name)
    if allowed:
        known = {ep.name for ep in eps} | {_dist_of(ep)[0] for ep in eps}
        for name in sorted(allowed - known):
            message = (
                f"{ENV_ALLOW} names {name!r}, which matches no installed plugin "
                f"(installed: {', '.join(f'{ep.name} ({_dist_of(ep)[0]})' for ep in eps) or 'none'})"
            )
            if pm.strict:
                raise PluginError(message)
            warn(message)
    for ep in eps:
        dist = _dist_of(ep)
        if allowed is not None and ep.name not in allowed and dist[0] not in allowed:
            continue
        if pm.has_plugin(ep.name):
            continue
        pm.dists[ep.name] = dist
        try:
            plugin = ep.load()
        except BaseException as exc:  # SystemExit or anything else a hostile import raises: one line, never an exit
            why = plugin_failure(exc, f"plugin {ep.name!r} from {dist[0]} (entry point {ep.value})")
            pm.skip(ep.name, f"cannot import {ep.value}: {why}")
            continue
        pm.add(plugin, ep.name)


def unknown_hooks(pm: pluggy.PluginManager) -> dict[str, list[str]]:
    """Plugin name -> hooks it implements that no hookspec declares."""
    found: dict[str, list[str]] = {}
    for name, caller in vars(pm.hook).items():
        if name.startswith("_") or caller.has_spec():
            continue
        for impl in caller.get_hookimpls():
            if not impl.optionalhook:
                found.setdefault(impl.plugin_name, []).append(name)
    return found


def _signature(name: str, args: tuple[str, ...]) -> str:
    return f"{name}({', '.join(args)})"


def spec_mismatch(pm: pluggy.PluginManager, plugin: object) -> str | None:
    """``hook register_heads(reg) does not match the spec register_heads(register)``, or None."""
    for attr in dir(plugin):
        opts = pm.parse_hookimpl_opts(plugin, attr)
        if opts is None:
            continue
        impl = pluggy.HookImpl(plugin, "", getattr(plugin, attr), opts)
        hook = opts.get("specname") or attr
        caller = getattr(pm.hook, hook, None)
        spec = caller.spec if caller is not None else None
        if spec is None or not set(impl.argnames) - {*spec.argnames, *spec.kwargnames}:
            continue
        return (
            f"hook {_signature(hook, (*impl.argnames, *impl.kwargnames))} does not match "
            f"the spec {_signature(hook, (*spec.argnames, *spec.kwargnames))}"
        )
    return None


def hook_hint(name: str) -> str:
    """`` (did you mean 'register_heads'?)`` for a misspelt hook name, else the list of hooks."""
    specs = sorted(n for n in dir(hookspecs) if n.startswith("register_"))
    close = difflib.get_close_matches(name, specs, n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}?" if close else f"hooks: {', '.join(specs)}"


def check_hooks(pm: DancePluginManager) -> None:
    """Skip (or, when strict, fail on) plugins implementing hooks that do not exist, naming the right one."""
    for plugin, hooks in unknown_hooks(pm).items():
        what = "; ".join(f"{h} is not a dance hook ({hook_hint(h)})" for h in hooks)
        if plugin in DEFAULT_PLUGINS or pm.strict:
            raise PluginError(f"plugin {plugin!r}: {what}")
        pm.skip(plugin, what)


def make_plugin_manager(load_entry_points: bool = True, strict: bool | None = None) -> DancePluginManager:
    """Build a manager with core's default plugins registered and (optionally) the installed ones."""
    from dance_core.version import __version__

    pm = DancePluginManager(strict=strict_from_env() if strict is None else strict)
    pm.add_hookspecs(hookspecs)
    for name, module in DEFAULT_PLUGINS.items():
        pm.register(importlib.import_module(module), name=name)
        pm.dists[name] = (CORE_PLUGIN, __version__)
    if load_entry_points:
        _load_entry_points(pm)
    check_hooks(pm)
    return pm


@lru_cache(maxsize=1)
def get_plugin_manager() -> DancePluginManager:
    """The process-wide plugin manager, built on first use."""
    return make_plugin_manager()


def plugin_distribution(pm: pluggy.PluginManager, plugin_name: str) -> tuple[str, str]:
    """The (distribution, version) that provided a registered plugin."""
    return getattr(pm, "dists", {}).get(plugin_name, (plugin_name, "unpackaged"))
