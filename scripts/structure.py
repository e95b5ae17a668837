"""dance-core's layers and its structure figures, read from the source with ``ast``.

``LAYERS`` is the one definition of the layers (bottom first): a module may import from its own
layer and the layers below, never from one above. ``imports`` walks every import of every module,
those inside functions and under ``if TYPE_CHECKING:`` included. The layer contract test
(packages/dance-core/tests/test_layers.py) reads both; ``python scripts/structure.py [SRC]`` prints
the figures recorded in docs/architecture.md (modules, internal imports, the share inside functions,
imports running up a layer, modules over 500 lines) and lists the imports that run up.
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

CORE = Path(__file__).resolve().parents[1] / "packages" / "dance-core" / "src"

#: bottom first: (layer, the modules and folders of ``dance_core`` in it; "" is the package itself)
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base", ("errors", "config", "version", "atomic", "checks", "media", "spans", "protocols", "contexts",
              "hookspecs", "progress", "shards", "row_generators", "runtime")),
    ("plugins", ("kinds", "contracts", "plugins", "registry")),
    ("recipe", ("recipe",)),
    ("motion", ("motion",)),
    ("formats", ("formats",)),
    ("components", ("components",)),
    ("data", ("data",)),
    ("synth", ("synth",)),
    ("render", ("render",)),
    ("evaluation", ("evaluation",)),
    ("loops", ("model", "checkpoint", "warm_start", "distributed", "train", "compose", "likelihood", "delivery")),
    ("face", ("", "api", "testing", "pytest_plugin")),
    ("live", ("live",)),
    ("cli", ("cli",)),
    ("defaults", ("defaults",)),
)

#: a module with more lines than this counts as long
LONG = 500


@dataclass(frozen=True)
class Import:
    """One import of a ``dance_core`` module by another."""

    source: str
    target: str
    line: int
    in_function: bool

    def __str__(self) -> str:
        where = " (in a function)" if self.in_function else ""
        return f"{self.source}:{self.line} imports {self.target}{where}"


def module_name(path: Path, root: Path = CORE) -> str:
    """``dance_core.a.b`` for ``root/dance_core/a/b.py`` (a package's ``__init__`` is the package)."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules(root: Path = CORE) -> dict[str, Path]:
    """Every module of ``dance_core`` under ``root``, by name."""
    return {module_name(p, root): p for p in sorted((root / "dance_core").rglob("*.py"))}


def layer_of(module: str) -> int:
    """The index in ``LAYERS`` of a ``dance_core`` module (its longest listed prefix); a ``KeyError``
    for a module no layer lists."""
    rest = module.removeprefix("dance_core").removeprefix(".")
    best, length = None, -1
    for index, (_, members) in enumerate(LAYERS):
        for member in members:
            inside = rest == member or (member and rest.startswith(member + ".")) or (not member and not rest)
            if inside and len(member) > length:
                best, length = index, len(member)
    if best is None:
        raise KeyError(f"{module}: in no layer of scripts/structure.py LAYERS")
    return best


def _walk(node: ast.AST, in_function: bool):
    for child in ast.iter_child_nodes(node):
        inside = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        if isinstance(child, (ast.Import, ast.ImportFrom)):
            yield child, in_function
        yield from _walk(child, inside)


def imports(path: Path, name: str, known: set[str]) -> list[Import]:
    """Every import of a ``dance_core`` module in the file ``path`` (module ``name``), at any depth;
    ``from a import b`` names ``a.b`` when that is a module, else ``a``."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node, in_function in _walk(ast.parse(path.read_text(encoding="utf-8")), False):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in known]
            targets = subs + ([base] if len(subs) < len(node.names) else [])
        found += [Import(name, t, node.lineno, in_function) for t in targets
                  if t.split(".")[0] == "dance_core" and t != name]
    return found


def all_imports(root: Path = CORE) -> list[Import]:
    """Every internal import of every module of ``dance_core`` under ``root``."""
    found = modules(root)
    return [imp for name, path in found.items() for imp in imports(path, name, set(found))]


def upward(found: list[Import]) -> list[Import]:
    """The imports whose target sits in a higher layer than their source."""
    return [i for i in found if layer_of(i.target) > layer_of(i.source)]


def figures(root: Path = CORE) -> dict[str, object]:
    """The structure figures of ``dance_core`` under ``root``."""
    found = modules(root)
    edges = all_imports(root)
    lines = {name: len(path.read_text(encoding="utf-8").splitlines()) for name, path in found.items()}
    long = sorted(name for name, n in lines.items() if n > LONG)
    return {
        "modules": len(found),
        "lines": sum(lines.values()),
        "internal imports": len(edges),
        "inside functions": sum(i.in_function for i in edges),
        "share inside functions": round(100 * sum(i.in_function for i in edges) / max(1, len(edges))),
        "imports up a layer": len(upward(edges)),
        "modules over 500 lines": [f"{n} ({lines[n]})" for n in long],
    }


def main(argv: list[str]) -> int:
    """Print the figures of the tree at ``argv[0]`` (a ``src`` folder; default: this checkout's core)."""
    root = Path(argv[0]) if argv else CORE
    for key, value in figures(root).items():
        print(f"{key}: {value}")
    for imp in upward(all_imports(root)):
        print(f"  up: {imp}  ({LAYERS[layer_of(imp.source)][0]} -> {LAYERS[layer_of(imp.target)][0]})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
