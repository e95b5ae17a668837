"""``dance plugin new NAME --kind KIND``: write a plugin package that installs, tests and trains.

Registered by core's default plugin ``dance_core.defaults.authoring`` through ``register_commands``.
The package is rendered from the templates in ``dance_core/templates/`` (``string.Template``,
``${field}`` placeholders): a shared pyproject, README and ``__init__``, and per kind an entry module,
a config, a small working component, an example recipe extending ``core-synthetic`` and tests that
use ``dance_core.testing``. It is written into a temporary folder beside the target and renamed into
place, so a failure leaves nothing half written; an existing folder is never overwritten.
"""

from __future__ import annotations

import argparse
import os
import re
import secrets
import shutil
import string
from dataclasses import dataclass
from importlib import resources
from importlib.metadata import entry_points
from pathlib import Path

from dance_core.errors import DanceError


@dataclass(frozen=True)
class Kind:
    """What ``dance plugin new`` writes for one component kind."""

    component: str  # the component's module, and the template of it
    summary: str  # one line: what the generated component does
    needs_torch: bool  # a model part (torch) or a numpy component
    recipe: bool = True  # whether an example recipe can swap it in
    registered_as: str = ""  # its kind in the registry (dance_core.kinds) when not the same word
    try_it: str = ""  # without an example recipe: a command that uses it ({name} filled in)
    check: str = ""  # its check in dance_core.testing (check_<kind> when empty)


KINDS: dict[str, Kind] = {
    "head": Kind("head", "a Gaussian MLP head: negative log-likelihood loss, sampled with temperature", True),
    "encoder": Kind("encoder", "a GRU over a window of past motion and music, or over the whole song", True),
    "conditioner": Kind("conditioner", "a per-frame linear + GELU embedding of one feature stream", True),
    "feature": Kind("feature", "RMS loudness of the music in dB, optionally with its rise", False),
    "metric": Kind("metric", "mean jerk of joint positions in m/s^3: lower is smoother", False, recipe=False,
                   try_it="dance evaluate --generated DIR --reference DIR --metrics {name}"),
    "dataset": Kind("dataset", "metronome songs with a dancer that sways and dips on the beat", False),
    "format": Kind("motion_format", "motion as CSV text: a row per frame, a column per channel, the fps on top",
                   False, recipe=False, registered_as="motion-format", check="component",
                   try_it="dance compose default --music SONG --format {name} -o out"),
    "reader": Kind("reader", "headerless PCM audio (.pcm, .raw) of a rate, channels and sample type given as options",
                   False, recipe=False, registered_as="audio-reader", check="component",
                   try_it="dance compose default --music SONG.pcm --set formats.{name}.rate=44100 -o out"),
}


def registry_kind(kind: str) -> str:
    """The registry's name of a ``--kind`` (``format`` -> ``motion-format``)."""
    return KINDS[kind].registered_as or kind


#: lowercase words of letters and digits joined by '-' or '_', starting with a letter
NAME = re.compile(r"[a-z][a-z0-9]*(?:[-_][a-z0-9]+)*")
#: dance's own distributions are dance-<one of these>
RESERVED = frozenset({"core", "audio", "flow", "rnn", "tokens"})


def add_parser(subparsers) -> None:
    """Add ``dance plugin`` with its ``new`` action."""
    p = subparsers.add_parser("plugin", help="tools for plugin authors (plugin new)",
                              epilog="examples:\n  dance plugin new myhead --kind head --out plugins")
    actions = p.add_subparsers(dest="plugin_command", metavar="ACTION", parser_class=type(p), required=True)
    new = actions.add_parser(
        "new",
        help="write a plugin package: a working component, tests and an example recipe",
        description="Write dance-NAME/: a package with the dance entry point, a small working component "
        "of the kind, tests that run dance_core.testing's contract checks and train its example recipe.",
        epilog="examples:\n"
        "  dance plugin new myhead --kind head\n"
        "  dance plugin new loudness --kind feature --out plugins\n"
        "  dance plugin new mocap-csv --kind format",
    )
    new.add_argument("name", help="component and plugin name: lowercase letters and digits, '-' or '_' between words")
    new.add_argument("--kind", required=True, choices=list(KINDS), help="the kind of component")
    new.add_argument("--out", default=".", metavar="DIR", help="folder to write dance-NAME/ into")
    new.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check the name and the folder, write the package and say what to do next."""
    from dance_core.checks import check_output_dir
    from dance_core.progress import say

    check_name(args.name, args.kind)
    check_output_dir(args.out, "--out")
    target = new_plugin(args.name, args.kind, args.out)
    n_files = sum(1 for p in target.rglob("*") if p.is_file())
    spec = KINDS[args.kind]
    try_it = f"dance train {args.name}-example --set training.steps=200" if spec.recipe else \
        spec.try_it.replace("{name}", args.name)
    say(args, f"wrote {target}/ ({args.kind} {args.name!r}, {n_files} files); next:", f"  pip install -e {target}",
        f"  pytest {target}", f"  {try_it}")
    return 0


def check_name(name: str, kind: str) -> None:
    """Refuse (one ``DanceError`` line) a malformed name, one of dance's own, or one already taken."""
    if not NAME.fullmatch(name) or len(name) > 40:
        raise DanceError(
            f"plugin name {name!r}: use lowercase letters and digits, words joined by '-' or '_', starting "
            "with a letter, at most 40 characters (e.g. myhead, gru-encoder)"
        )
    if name in RESERVED:
        raise DanceError(f"plugin name {name!r}: dance-{name} is one of dance's own packages; choose another name")
    if kind not in KINDS:
        raise DanceError(f"unknown kind {kind!r}; kinds: {', '.join(KINDS)}")
    from dance_core.plugins import GROUP
    from dance_core.registry import get_registry

    for ep in entry_points(group=GROUP):
        if ep.name == name:
            dist = ep.dist.metadata["name"] if ep.dist is not None else "?"
            raise DanceError(f"plugin name {name!r}: the installed plugin {name!r} ({dist}) has it; choose another")
    registry = get_registry()
    if name in registry.names(registry_kind(kind)):
        entry = registry.get(registry_kind(kind), name)
        raise DanceError(
            f"plugin name {name!r}: {entry.kind} {name!r} is already registered by plugin {entry.plugin!r} "
            f"({entry.distribution}); choose another name"
        )


def core_requirement(version: str) -> str:
    """``dance-core>=0.1,<0.2`` for core 0.1.x: the minor series a plugin is written against
    (for 1.x and later, the major series)."""
    major, minor = (int(part) for part in (version.split(".") + ["0", "0"])[:2])
    upper = f"{major}.{minor + 1}" if major == 0 else f"{major + 1}"
    return f"dance-core>={major}.{minor},<{upper}"


def _template(kind: str, file: str) -> str:
    return resources.files("dance_core").joinpath("templates", kind, file).read_text(encoding="utf-8")


def render(name: str, kind: str) -> dict[str, str]:
    """The package's files, relative path -> text, for component ``name`` of ``kind``."""
    from dance_core import __version__

    spec = KINDS[kind]
    pyname = name.replace("-", "_")
    module = f"dance_{pyname}"
    deps = [core_requirement(__version__), "pydantic>=2.6,<3", "torch>=2.1" if spec.needs_torch else "numpy>=1.24"]
    fields = {
        "name": name,
        "entry": name,
        "pyname": pyname,
        "module": module,
        "dist": f"dance-{name}",
        "cls": "".join(word.capitalize() for word in re.split(r"[-_]", name)),
        "kind": kind,
        "listed": registry_kind(kind),
        "component": spec.component,
        "check": spec.check or kind,
        "summary": spec.summary,
        "recipe": f"{name}-example",
        "dependencies": ", ".join(f'"{dep}"' for dep in deps),
        "trains_note": "\nThen the example recipe trains for a few steps." if spec.recipe else "",
        "trains_row": " and a short training run of the example recipe" if spec.recipe else "",
        "recipe_row": (
            f"| `src/{module}/recipes/{name}-example.yaml` | the example recipe: `core-synthetic` with this {kind} |\n"
            if spec.recipe
            else ""
        ),
    }
    fields["usage"] = string.Template(_template(kind, "usage.md.tmpl")).substitute(fields).strip()
    files = {
        "pyproject.toml": ("common", "pyproject.toml.tmpl"),
        "README.md": ("common", "README.md.tmpl"),
        f"src/{module}/__init__.py": ("common", "__init__.py.tmpl"),
        f"src/{module}/plugin.py": (kind, "plugin.py.tmpl"),
        f"src/{module}/configs.py": (kind, "configs.py.tmpl"),
        f"src/{module}/{spec.component}.py": (kind, "component.py.tmpl"),
        f"tests/test_{pyname}.py": (kind, "test.py.tmpl"),
    }
    if spec.recipe:
        files[f"src/{module}/recipes/{name}-example.yaml"] = (kind, "recipe.yaml.tmpl")
    return {path: string.Template(_template(*where)).substitute(fields) for path, where in files.items()}


def new_plugin(name: str, kind: str, out: str | Path = ".") -> Path:
    """Write ``dance-NAME/`` into ``out`` and return its path; the folder must not exist yet."""
    check_name(name, kind)
    out = Path(out)
    target = out / f"dance-{name}"
    if target.exists() or target.is_symlink():
        raise DanceError(f"{target} already exists; not overwriting it (remove it or choose another --out)")
    files = render(name, kind)
    out.mkdir(parents=True, exist_ok=True)
    staging = out / f".dance-{name}-{secrets.token_hex(4)}.tmp"
    staging.mkdir()
    try:
        for relative, text in files.items():
            path = staging / relative
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
        if target.exists():  # appeared while writing: still never overwrite
            raise DanceError(f"{target} already exists; not overwriting it (remove it or choose another --out)")
        os.rename(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return target
