"""The public API holds: first-party plugins import only ``dance_core``'s exported names, core imports
no plugin, no module-level import cycle in core, and ``import dance_core`` stays light."""

import ast
import subprocess
import sys
from pathlib import Path

import dance_core

PACKAGES = Path(__file__).resolve().parents[2]
CORE = PACKAGES / "dance-core" / "src"
PLUGINS = ("dance-audio", "dance-flow", "dance-rnn", "dance-tokens")


def imports(path: Path, top_level_only: bool = False) -> list[tuple[str, list[str]]]:
    """(module, names) of every ``from X import names`` / ``import X`` in a file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    nodes = tree.body if top_level_only else ast.walk(tree)
    found = []
    for node in nodes:
        if isinstance(node, ast.ImportFrom) and node.module:
            found.append((node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            found.extend((a.name, []) for a in node.names)
    return found


def test_first_party_plugins_import_only_the_public_api():
    bad = []
    for package in PLUGINS:
        for path in (PACKAGES / package / "src").rglob("*.py"):
            for module, names in imports(path):
                if module.startswith("dance_core") and module != "dance_core":
                    bad.append(f"{path.relative_to(PACKAGES)}: from {module} import {', '.join(names)}")
                elif module == "dance_core":
                    bad += [f"{path.relative_to(PACKAGES)}: {n} is not exported" for n in names
                            if n not in dance_core.__all__]
    assert not bad, "\n".join(bad)


def test_every_exported_name_resolves():
    for name in dance_core.__all__:
        assert getattr(dance_core, name) is not None, name


def test_core_imports_no_plugin():
    bad = [f"{p.relative_to(CORE)}: {m}" for p in CORE.rglob("*.py") for m, _ in imports(p)
           if m.split(".")[0] in {"dance_audio", "dance_flow", "dance_rnn", "dance_tokens"}]
    assert not bad, bad


def _module_name(path: Path) -> str:
    parts = path.relative_to(CORE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_no_module_level_import_cycle_in_core():
    modules = {_module_name(p): p for p in CORE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        deps = set()
        for module, names in imports(path, top_level_only=True):
            for target in [f"{module}.{n}" for n in names] + [module]:
                if target in modules and target != name:
                    deps.add(target)
                    break
        graph[name] = deps
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for dep in sorted(graph[node]):
            assert state.get(dep) != 1, "import cycle: " + " -> ".join(trail[trail.index(dep):] + [dep])
            if dep not in state:
                visit(dep, trail + [dep])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])


def test_importing_dance_core_and_its_registry_loads_no_torch():
    code = ("import sys, dance_core; from dance_core.registry import get_registry; get_registry(); "
            "print(sorted(m for m in ('torch', 'matplotlib', 'librosa', 'madmom') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_stable_api_table_in_the_docs_is_generated_from_all():
    import importlib.util

    script = PACKAGES.parent / "scripts" / "api_table.py"
    spec = importlib.util.spec_from_file_location("api_table", script)
    api_table = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(api_table)
    doc = api_table.DOC.read_text(encoding="utf-8")
    assert api_table.with_table(doc) == doc, "the stable-API table is stale: run python scripts/api_table.py --write"
    listed = {name.strip("`") for _, names in api_table.plugin_rows() for name in names}
    assert listed == set(dance_core.__all__)
