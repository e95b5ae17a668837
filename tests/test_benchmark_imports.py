"""The benchmarks use dance-core's public API only: ``dance_core``'s exported names, ``dance_core.api``
and the library modules listed in the stable-API table (``dance_core.motion``, ``dance_core.evaluation``,
``dance_core.synth``), each name in its module's ``__all__``; every import counts, those inside
functions included."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"

#: the dance-core modules a script may import from (their ``__all__``)
PUBLIC = ("dance_core", "dance_core.api", "dance_core.motion", "dance_core.evaluation", "dance_core.synth")


def core_imports(path: Path) -> list[tuple[int, str, list[str]]]:
    """(line, module, names) of every import of a ``dance_core`` module in a file."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "dance_core":
            found.append((node.lineno, node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name, []) for a in node.names if a.name.split(".")[0] == "dance_core"]
    return found


def test_benchmarks_import_only_the_public_api():
    exported = {name: set(importlib.import_module(name).__all__) for name in PUBLIC}
    bad = []
    for path in sorted(BENCHMARKS.glob("*.py")):
        for line, module, names in core_imports(path):
            where = f"{path.name}:{line}"
            if module not in exported:
                bad.append(f"{where}: {module} is not public (use {', '.join(PUBLIC)})")
                continue
            bad += [f"{where}: {module}.{n} is not in its __all__" for n in names if n not in exported[module]]
    assert not bad, "\n".join(bad)


def test_every_public_script_name_resolves():
    for name in PUBLIC[1:]:
        module = importlib.import_module(name)
        for attr in module.__all__:
            assert getattr(module, attr) is not None, f"{name}.{attr}"
