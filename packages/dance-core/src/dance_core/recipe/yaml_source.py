"""Safe YAML parsing that remembers where every value came from (file and line)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from dance_core.errors import RecipeError


class RecipeLoader(yaml.SafeLoader):
    """A safe loader that reads ``1e-4`` as a number (YAML 1.2 floats), not a string."""


RecipeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+][0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


@dataclass
class Source:
    """A parsed YAML document: its data, its node tree and where it came from."""

    data: Any
    node: yaml.Node | None
    origin: str

    def line_of(self, path: tuple[Any, ...]) -> tuple[int, int] | None:
        """(line, depth matched) of the deepest node along ``path``, 1-based; None if absent."""
        node = self.node
        if node is None:
            return None
        line = node.start_mark.line + 1
        depth = 0
        for key in path:
            child = _child(node, key)
            if child is None:
                continue  # a location part that is not a key (e.g. a union tag): skip it
            node = child
            depth += 1
            line = node.start_mark.line + 1
        return line, depth


def _child(node: yaml.Node, key: Any) -> yaml.Node | None:
    if isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            if k.value == str(key):
                return v
    elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and 0 <= key < len(node.value):
        return node.value[key]
    return None


def parse_text(text: str, origin: str) -> Source:
    """Parse YAML text safely; a syntax error names the origin and line."""
    try:
        node = yaml.compose(text, Loader=RecipeLoader)
        data = yaml.load(text, Loader=RecipeLoader)  # RecipeLoader is a SafeLoader
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f":{mark.line + 1}" if mark is not None else ""
        raise RecipeError(f"{origin}{line}: invalid YAML: {exc.problem or exc}") from None
    except yaml.YAMLError as exc:
        raise RecipeError(f"{origin}: invalid YAML: {exc}") from None
    return Source(data, node, origin)


def parse_file(path: Path) -> Source:
    """Parse a recipe file; a missing or unreadable file is a one-line error."""
    if path.is_dir():
        raise RecipeError(f"{path}: is a folder, not a recipe file")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RecipeError(f"{path}: recipe file not found") from None
    except UnicodeDecodeError:
        raise RecipeError(f"{path}: not a recipe: not UTF-8 text") from None
    except OSError as exc:
        raise RecipeError(f"{path}: cannot read recipe: {exc.strerror or exc}") from None
    source = parse_text(text, str(path))
    if source.data is None:
        raise RecipeError(f"{path}: recipe file is empty (it needs at least name: and model:, or extends:)")
    if not isinstance(source.data, dict):
        raise RecipeError(f"{path}:1: a recipe must be a mapping of fields, not a {type(source.data).__name__}")
    return source


def parse_value(text: str) -> Any:
    """Parse one ``--set`` value as YAML (so ``1e-4`` is a number and ``[1, 2]`` a list)."""
    try:
        return yaml.load(text, Loader=RecipeLoader)  # RecipeLoader is a yaml.SafeLoader
    except yaml.YAMLError:
        return text
