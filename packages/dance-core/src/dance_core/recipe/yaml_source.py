"""Safe YAML parsing that remembers where every value came from (file and line)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from dance_core.errors import RecipeError

#: limits on a YAML document (a recipe, a rig map, a ``--set`` value): its size in characters, the
#: nesting of its mappings and lists, its aliases, and the values it holds once aliases are expanded
MAX_CHARS = 1_000_000
MAX_DEPTH = 64
MAX_ALIASES = 100
MAX_VALUES = 100_000
#: longest integer literal read (a 64-bit number has at most 20 digits)
MAX_INT_CHARS = 24

_INT, _FLOAT, _MERGE = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float", "tag:yaml.org,2002:merge"


class _Limit(Exception):
    """A document past one of the limits, at a mark."""

    def __init__(self, mark: Any, message: str):
        super().__init__(message)
        self.mark = mark


class RecipeLoader(yaml.SafeLoader):
    """A safe loader that reads ``1e-4`` as a number (YAML 1.2 floats), not a string, and stops a
    document nested deeper than ``MAX_DEPTH`` or holding more than ``MAX_ALIASES`` aliases while
    composing it (before anything is expanded)."""

    def __init__(self, stream: Any):
        super().__init__(stream)
        self._depth = 0
        self._aliases = 0

    def compose_node(self, parent: Any, index: Any) -> Any:  # noqa: D102 - PyYAML hook
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise _Limit(self.peek_event().start_mark, f"more than {MAX_ALIASES} aliases (*name); "
                             "a recipe needs few")
            return super().compose_node(parent, index)
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _Limit(self.peek_event().start_mark, f"nested deeper than {MAX_DEPTH} levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


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


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def _check_scalar(loader: RecipeLoader, node: yaml.ScalarNode) -> None:
    if node.tag == _INT and len(node.value) > MAX_INT_CHARS:
        raise _Limit(node.start_mark, f"integer of {len(node.value)} characters is too large (at most "
                     f"{MAX_INT_CHARS}; a recipe's numbers fit in 64 bits)")
    if node.tag == _FLOAT and not math.isfinite(loader.construct_yaml_float(node)):
        raise _Limit(node.start_mark, f"{node.value!r} is not a finite number (NaN and infinities are refused)")


def _check_mapping(node: yaml.MappingNode) -> None:
    first: dict[str, int] = {}
    for key, _ in node.value:
        if not isinstance(key, yaml.ScalarNode) or key.tag == _MERGE:
            continue
        if key.value in first:
            raise _Limit(key.start_mark, f"duplicate key {key.value!r} (first at line {first[key.value]})")
        first[key.value] = key.start_mark.line + 1


def check_document(loader: RecipeLoader, root: yaml.Node) -> None:
    """Refuse (``_Limit``) a duplicate key, a non-finite or oversized number, an alias that contains
    itself, and a document holding more than ``MAX_VALUES`` values once its aliases are expanded (an
    alias bomb): each distinct node is looked at once, without recursion."""
    size: dict[int, int] = {}
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    open_nodes: set[int] = set()
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            open_nodes.discard(key)
            size[key] = 1 + sum(size[id(c)] for c in _children(node))
            if size[key] > MAX_VALUES:
                raise _Limit(node.start_mark, f"expands to more than {MAX_VALUES} values through its aliases "
                             "(an alias bomb?)")
            continue
        if key in size:
            continue
        if key in open_nodes:
            raise _Limit(node.start_mark, "an alias refers to the node that contains it (a recursive alias)")
        open_nodes.add(key)
        if isinstance(node, yaml.ScalarNode):
            _check_scalar(loader, node)
        elif isinstance(node, yaml.MappingNode):
            _check_mapping(node)
        stack.append((node, True))
        stack.extend((c, False) for c in _children(node) if id(c) not in size)


def _load(text: str, origin: str, lines: bool = True) -> tuple[Any, yaml.Node | None]:
    if len(text) > MAX_CHARS:
        raise RecipeError(f"{origin}: {len(text)} characters of YAML; at most {MAX_CHARS} are read")
    loader = RecipeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None, None
        check_document(loader, node)
        return loader.construct_document(node), node
    except _Limit as exc:
        raise RecipeError(f"{origin}:{exc.mark.line + 1}: {exc}" if lines else f"{origin}: {exc}") from None
    except RecursionError:
        raise RecipeError(f"{origin}: nested too deeply to read") from None
    finally:
        loader.dispose()


def parse_text(text: str, origin: str) -> Source:
    """Parse YAML text safely, within the limits above; a syntax error, a duplicate key or a value past
    a limit names the origin and line."""
    try:
        data, node = _load(text, origin)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f":{mark.line + 1}" if mark is not None else ""
        raise RecipeError(f"{origin}{line}: invalid YAML: {' '.join(str(exc.problem or exc).split())}") from None
    except yaml.YAMLError as exc:  # a reader error (a control character, bad encoding): one line
        raise RecipeError(f"{origin}: invalid YAML: {' '.join(str(exc).split())}") from None
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


def parse_value(text: str, origin: str = "--set") -> Any:
    """Parse one ``--set`` value as YAML (so ``1e-4`` is a number and ``[1, 2]`` a list), within the
    limits of a recipe (a non-finite number, a duplicate key, an alias bomb: one line naming ``origin``);
    text that is not YAML stays text."""
    try:
        return _load(text, origin, lines=False)[0]
    except yaml.YAMLError:
        return text
