"""Load a recipe: ``extends:``, ``--set`` overrides, validation, and one-line errors with lines."""

from __future__ import annotations

import copy
import difflib
import typing
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from dance_core.contexts import FormatOptions
from dance_core.errors import PluginError, RecipeError
from dance_core.recipe.schema import Recipe, resolve_paths
from dance_core.recipe.yaml_source import Source, parse_file, parse_value
from dance_core.registry import Registry, get_registry, unknown_message

MAX_EXTENDS = 16


def dotted(loc: tuple[Any, ...]) -> str:
    """``('model', 'head', 'n_layers')`` -> ``model.head.n_layers``."""
    return ".".join(str(part) for part in loc)


class SourceMap:
    """Finds the file and line that defined a field, across ``extends:`` and ``--set``."""

    def __init__(self) -> None:
        self.sources: list[Source] = []  # most derived last
        self.overrides: dict[tuple[str, ...], str] = {}

    def where(self, loc: tuple[Any, ...]) -> str:
        """``file:line`` (or ``--set a.b=c``) for a field location."""
        key = tuple(str(p) for p in loc)
        for path, text in self.overrides.items():
            if key[: len(path)] == path:
                return f"--set {text}"
        best: tuple[int, str] | None = None
        for source in reversed(self.sources):
            found = source.line_of(loc)
            if found is not None and (best is None or found[1] > best[0]):
                best = (found[1], f"{source.origin}:{found[0]}")
        if best:
            return best[1]
        return f"{self.sources[-1].origin}:1" if self.sources else "<recipe>"

    def folder_of(self, loc: tuple[Any, ...]) -> str | None:
        """The folder of the recipe file that wrote a field (None for ``--set`` and unknown fields)."""
        where = self.where(loc)
        if where.startswith("--set") or where == "<recipe>":
            return None
        return str(Path(where.rsplit(":", 1)[0]).parent)


def _other_component(base: Any, value: Any) -> bool:
    """True when ``value`` names a different plugin than ``base``: the component is replaced, not merged."""
    return isinstance(base, dict) and "plugin" in value and value.get("plugin") != base.get("plugin")


def deep_merge(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """Merge mappings recursively; anything else in ``override`` replaces the base value, and so does a
    component (``{plugin: ...}``) naming another plugin: the base's options belong to the base's plugin."""
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict) and not _other_component(merged[key], value):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def _locate_base(name: str, relative_to: Path, registry: Registry) -> Path:
    candidate = (relative_to / name).expanduser()
    if candidate.exists():
        return candidate
    if name in registry.names("recipe"):
        return Path(str(registry.get("recipe", name).target))
    raise RecipeError(
        f"extends: {name!r} is neither a file next to the recipe nor a bundled recipe "
        f"({', '.join(registry.names('recipe')) or 'none installed'})"
    )


def _read_with_bases(path: Path, smap: SourceMap, registry: Registry) -> dict[str, Any]:
    chain: list[Source] = []
    seen: set[Path] = set()
    current: Path | None = path
    while current is not None:
        resolved = current.resolve()
        if resolved in seen or len(chain) > MAX_EXTENDS:
            raise RecipeError(f"{current}: 'extends' forms a cycle")
        seen.add(resolved)
        source = parse_file(current)
        chain.append(source)
        base = source.data.get("extends")
        if base is not None and not isinstance(base, str):
            line = source.line_of(("extends",))
            raise RecipeError(f"{source.origin}:{line[0] if line else 1}: extends: must be a name")
        current = _locate_base(base, current.parent, registry) if base else None
    data: dict[str, Any] = {}
    for source in reversed(chain):
        data = deep_merge(data, source.data)
        smap.sources.append(source)
    data.pop("extends", None)
    return data


def apply_override(data: dict[str, Any], assignment: str, smap: SourceMap) -> None:
    """Apply one ``a.b=c`` override in place (``c`` parsed as YAML)."""
    key, sep, raw = assignment.partition("=")
    if not sep or not key.strip():
        raise RecipeError(f"--set {assignment!r}: expected FIELD.PATH=VALUE")
    parts = key.strip().split(".")
    node: Any = data
    for i, part in enumerate(parts[:-1]):
        if isinstance(node, list):
            node = _list_item(node, part, assignment)
        else:
            nxt = node.get(part)
            if nxt is None:
                nxt = node[part] = {}
            elif not isinstance(nxt, (dict, list)):
                raise RecipeError(f"--set {assignment}: {'.'.join(parts[: i + 1])} is not a mapping")
            node = nxt
    value = parse_value(raw, f"--set {assignment}")
    if isinstance(node, list):
        index = int(parts[-1]) if parts[-1].lstrip("-").isdigit() else None
        if index is None or not -len(node) <= index < len(node):
            raise RecipeError(f"--set {assignment}: no list item {parts[-1]!r}")
        node[index] = value
    else:
        node[parts[-1]] = value
    smap.overrides[tuple(parts)] = assignment


def _list_item(node: list[Any], part: str, assignment: str) -> Any:
    if not part.lstrip("-").isdigit() or not -len(node) <= int(part) < len(node):
        raise RecipeError(f"--set {assignment}: no list item {part!r}")
    return node[int(part)]


def _render(errors: list[dict[str, Any]], smap: SourceMap, prefix: tuple[Any, ...] = (),
            model: Any = Recipe) -> list[str]:
    lines = []
    for err in errors:
        loc = prefix + tuple(err["loc"])
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "missing":
            msg = "required field is missing"
        elif err["type"] == "extra_forbidden" and err["loc"]:
            msg = f"unknown field{_did_you_mean(str(err['loc'][-1]), _field_names(model, err['loc'][:-1]))}"
        lines.append(f"{smap.where(loc)}: {dotted(loc) or '(top level)'}: {msg}")
    return lines


def _did_you_mean(word: str, known: list[str]) -> str:
    """`` (did you mean 'steps'?)`` when ``word`` is close to one of ``known`` (difflib), else ``""``."""
    close = difflib.get_close_matches(word, known, n=3, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def _field_names(model: Any, path: tuple[Any, ...]) -> list[str]:
    """The fields (and aliases) of the pydantic model found at ``path`` inside ``model``; list indices and
    mapping keys (``features.music.0``) are stepped over."""
    for part in path:
        field = getattr(model, "model_fields", {}).get(part) if isinstance(part, str) else None
        if field is not None:
            model = _model_in(field.annotation)
    fields = getattr(model, "model_fields", {})
    return [*fields, *(f.alias for f in fields.values() if f.alias)]


def _model_in(annotation: Any) -> Any:
    """The pydantic model an annotation holds (itself, or inside ``list[...]``, ``dict[str, ...]``, ``| None``)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return next((m for m in map(_model_in, typing.get_args(annotation)) if m is not None), None)


def _component_problems(
    kind: str, loc: tuple[Any, ...], plugin: str, options: dict[str, Any], smap: SourceMap, registry: Registry
) -> tuple[list[str], Any, Any]:
    """(error lines, entry, validated config) of one component's plugin name and options."""
    try:
        entry = registry.get(kind, plugin)
    except PluginError as exc:
        return [f"{smap.where(loc + ('plugin',))}: {dotted(loc)}.plugin: {exc}"], None, None
    try:
        return [], entry, entry.validate(options)
    except ValidationError as exc:
        return _render(exc.errors(), smap, loc, entry.config), entry, None
    except PluginError as exc:
        return [f"{smap.where(loc)}: {dotted(loc)}: {exc}"], entry, None


#: the kinds a recipe's ``formats:`` gives options to
FILE_KINDS = ("motion-format", "audio-reader")


def _format_problems(
    recipe: Recipe, smap: SourceMap, registry: Registry
) -> tuple[list[str], dict[tuple[str, str], Any]]:
    """(error lines, validated configs by (kind, name)) of the recipe's ``formats:``, paths resolved."""
    problems: list[str] = []
    configs: dict[tuple[str, str], Any] = {}
    for name, options in recipe.formats.items():
        loc = ("formats", name)
        kinds = [kind for kind in FILE_KINDS if name in registry.names(kind)]
        if not kinds:
            known = sorted({n for kind in FILE_KINDS for n in registry.names(kind)})
            message = unknown_message("motion format or audio reader", name, known)
            problems.append(f"{smap.where(loc)}: {dotted(loc)}: {message}")
        for kind in kinds:
            lines, _, config = _component_problems(kind, loc, name, options, smap, registry)
            problems += lines
            if not lines and config is not None:
                configs[(kind, name)] = resolve_paths(config, smap.folder_of(loc) or recipe._dir)
    return problems, configs


def validate_components(recipe: Recipe, smap: SourceMap, registry: Registry) -> None:
    """Validate every component's options with its plugin's config model, and the ``formats:`` options."""
    problems, configs = _format_problems(recipe, smap, registry)
    recipe._formats = FormatOptions(configs)
    for kind, loc, spec in recipe.components():
        lines, entry, config = _component_problems(kind, loc, spec.plugin, spec.options(), smap, registry)
        problems += lines
        if entry is not None:
            spec._entry = entry
        if not lines:
            spec._config = config
            spec._base = smap.folder_of(loc) or recipe._dir
    if problems:
        raise RecipeError("\n".join(problems))


def _raw_components(data: Any) -> list[tuple[str, tuple[Any, ...], Any]]:
    """(kind, location, mapping) of every component place in an unvalidated recipe (as ``Recipe.components``)."""

    def get(node: Any, *keys: str) -> Any:
        for key in keys:
            node = node.get(key) if isinstance(node, dict) else None
        return node

    found: list[tuple[str, tuple[Any, ...], Any]] = []
    features = get(data, "features")
    for stream, specs in features.items() if isinstance(features, dict) else ():
        for i, spec in enumerate(specs if isinstance(specs, list) else ()):
            found.append(("feature", ("features", stream, i), spec))
    for kind, keys in (("conditioner", ("model", "conditioners")), ("schedule", ("training", "schedules"))):
        named = get(data, *keys)
        for name, spec in named.items() if isinstance(named, dict) else ():
            found.append((kind, (*keys, name), spec))
    for kind, keys in (
        ("motion-representation", ("motion",)),
        ("encoder", ("model", "encoder")),
        ("head", ("model", "head")),
        ("dataset", ("data", "dataset")),
        ("schedule", ("training", "lr_schedule")),
    ):
        found.append((kind, keys, get(data, *keys)))
    return found


def _schema_and_component_errors(
    exc: ValidationError, data: dict[str, Any], smap: SourceMap, registry: Registry
) -> RecipeError:
    """Every class of error at once: the schema's, then those of each component the schema did not reject."""
    lines = _render(exc.errors(), smap)
    bad = [tuple(str(p) for p in err["loc"]) for err in exc.errors()]
    for kind, loc, spec in _raw_components(data):
        if not isinstance(spec, dict) or not isinstance(spec.get("plugin"), str):
            continue
        key = tuple(str(p) for p in loc)
        if any(b[: len(key)] == key for b in bad):
            continue  # the schema already reported this component
        options = {k: v for k, v in spec.items() if k != "plugin"}
        lines += _component_problems(kind, loc, spec["plugin"], options, smap, registry)[0]
    return RecipeError("\n".join(lines))


def load_recipe(
    path: str | Path,
    overrides: list[str] | tuple[str, ...] = (),
    registry: Registry | None = None,
) -> Recipe:
    """Read, merge, override and validate a recipe file (or a bundled recipe name)."""
    registry = registry or get_registry()
    path = Path(path)
    if not path.exists() and path.suffix == "":
        if str(path) in registry.names("recipe"):
            path = Path(str(registry.get("recipe", str(path)).target))
        else:
            bundled = ", ".join(registry.names("recipe")) or "none installed"
            hint = _did_you_mean(str(path), registry.names("recipe"))
            raise RecipeError(f"{path}: no such recipe file or bundled recipe{hint} (bundled: {bundled})")
    smap = SourceMap()
    data = _read_with_bases(path, smap, registry)
    for assignment in overrides:
        apply_override(data, assignment, smap)
    try:
        recipe = Recipe.model_validate(data)
    except ValidationError as exc:
        raise _schema_and_component_errors(exc, data, smap, registry) from None
    recipe._dir = str(path.parent)
    recipe._origin = str(path)
    validate_components(recipe, smap, registry)
    return recipe


def recipe_from_dict(data: dict[str, Any], base_dir: str = ".", registry: Registry | None = None) -> Recipe:
    """Validate a recipe given as a mapping (for instance from a checkpoint's metadata)."""
    smap = SourceMap()
    try:
        recipe = Recipe.model_validate(data)
    except ValidationError as exc:
        raise RecipeError("\n".join(_render(exc.errors(), smap))) from None
    recipe._dir = base_dir
    validate_components(recipe, smap, registry or get_registry())
    return recipe
