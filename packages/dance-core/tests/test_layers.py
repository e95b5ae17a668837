"""The layer contract: no module of dance-core imports from a layer above its own.

The layers are defined once, in ``scripts/structure.py`` (``LAYERS``, bottom first; drawn in
docs/architecture.md, "Layers"). Every import counts: at module level, inside functions and under
``if TYPE_CHECKING:``.
"""

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]

#: imports allowed to run up a layer, ``(source module, target module)`` -> why; at most one, each justified
ALLOWED: dict[tuple[str, str], str] = {}


def _structure():
    spec = importlib.util.spec_from_file_location("dance_structure", ROOT / "scripts" / "structure.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


structure = _structure()


def test_every_module_is_in_a_layer():
    unplaced = []
    for name in structure.modules():
        try:
            structure.layer_of(name)
        except KeyError as exc:
            unplaced.append(str(exc))
    assert not unplaced, "\n".join(unplaced)


def test_no_import_runs_up_a_layer():
    assert len(ALLOWED) <= 1, "at most one upward import may be allowed"
    found = [i for i in structure.upward(structure.all_imports()) if (i.source, i.target) not in ALLOWED]
    layer = {i: structure.LAYERS[structure.layer_of(i)][0] for imp in found for i in (imp.source, imp.target)}
    assert not found, "imports running up a layer:\n" + "\n".join(
        f"  {imp} ({layer[imp.source]} -> {layer[imp.target]})" for imp in found)


def test_every_allowed_import_still_exists():
    edges = {(i.source, i.target) for i in structure.all_imports()}
    assert not set(ALLOWED) - edges, "an allowed upward import is gone: remove it from ALLOWED"


@pytest.fixture
def tree(tmp_path):
    """A small ``dance_core`` tree: a base module, a motion module, a cli module."""
    pkg = tmp_path / "dance_core"
    (pkg / "motion").mkdir(parents=True)
    (pkg / "cli").mkdir()
    for path in (pkg / "__init__.py", pkg / "motion" / "__init__.py", pkg / "cli" / "__init__.py", pkg / "errors.py",
                 pkg / "cli" / "main.py"):
        path.write_text('"""x"""\n')
    return tmp_path


def test_imports_inside_functions_and_type_checking_blocks_count(tree):
    (tree / "dance_core" / "motion" / "fk.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "from dance_core.errors import DanceError\n"
        "if TYPE_CHECKING:\n    from dance_core.cli import main\n"
        "def f():\n    from ..cli.main import run\n    return run\n")
    up = structure.upward(structure.all_imports(tree))
    assert [(i.source, i.target, i.in_function) for i in up] == [
        ("dance_core.motion.fk", "dance_core.cli.main", False),
        ("dance_core.motion.fk", "dance_core.cli.main", True),
    ]


def test_a_module_in_no_layer_is_named(tree):
    (tree / "dance_core" / "misc.py").write_text('"""x"""\n')
    with pytest.raises(KeyError, match="dance_core.misc: in no layer"):
        structure.layer_of("dance_core.misc")
