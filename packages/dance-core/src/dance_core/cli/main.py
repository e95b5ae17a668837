"""``dance``: argument parsing and error reporting; each command lives in its own small module."""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import textwrap

from dance_core.checks import bounded_number
from dance_core.cli import commands
from dance_core.cli.checks import shard_arg, smpl_model_option, use_smpl_model
from dance_core.errors import DanceError, describe_error
from dance_core.plugins import DEFAULT_PLUGINS, ENV_STRICT


class HelpFormatter(argparse.HelpFormatter):
    """Wraps prose but keeps indented lines (examples, forms) as written; adds ``(default: X)`` where an
    option has a real default."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        lines = []
        for line in text.splitlines():
            if line[:1].isspace() or not line:
                lines.append(indent + line)
            else:
                lines.extend(textwrap.wrap(line, width, initial_indent=indent, subsequent_indent=indent))
        return "\n".join(lines)

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (
            default is None
            or default is False
            or default is argparse.SUPPRESS
            or default in ([], ())
            or "default" in text
            or not (action.option_strings or action.nargs in ("?", "*"))
        ):
            return text
        shown = " ".join(map(str, default)) if isinstance(default, (list, tuple)) else str(default)
        return f"{text} (default: {shown.replace('%', '%%')})"


class Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line on stderr, exit code 2; help shows defaults."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)
        self.command_groups: list[argparse._SubParsersAction] = []

    def add_subparsers(self, **kwargs):  # noqa: D102 - remembers the groups, to add the common flags later
        action = super().add_subparsers(**kwargs)
        self.command_groups.append(action)
        return action

    def _get_values(self, action, arg_strings):  # noqa: D102 - argparse hook: no empty value anywhere
        if isinstance(arg_strings, list) and any(not a.strip() for a in arg_strings if isinstance(a, str)):
            if not isinstance(action, argparse._SubParsersAction):
                name = "/".join(action.option_strings) or action.metavar or action.dest
                self.error(f"argument {name}: empty value (give a file, folder or value, not '')")
        return super()._get_values(action, arg_strings)

    def error(self, message: str):  # noqa: D102 - argparse hook
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


#: flags accepted before the subcommand and after it (pip's habit): (flags, help)
COMMON_FLAGS = (
    (("--debug",), "show tracebacks for errors"),
    (("-q", "--quiet"), "no progress bars or summaries"),
    (("--strict",), f"stop on a broken plugin instead of skipping it ({ENV_STRICT}=1)"),
    (("--json",), "print one JSON object on stdout, errors included ({\"error\": ..., \"exit_code\": N})"),
)


def _add_common_flags(parser: argparse.ArgumentParser) -> None:
    """Give every subcommand (and theirs) the common flags, defaulting to what came before the subcommand."""
    for group in getattr(parser, "command_groups", ()):
        for child in dict.fromkeys(group.choices.values()):  # aliases share one parser
            for flags, text in COMMON_FLAGS:
                with contextlib.suppress(argparse.ArgumentError):  # a plugin's command took the flag itself
                    child.add_argument(*flags, action="store_true", default=argparse.SUPPRESS, help=text)
            _add_common_flags(child)


def _examples(*lines: str) -> str:
    return "examples:\n" + "\n".join(f"  {line}" for line in lines)


def _sets(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--set",
        dest="sets",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="override a recipe field, e.g. --set training.steps=100 (repeatable)",
    )


def _plugin_commands(sub) -> None:
    """Subcommands from every plugin's ``register_commands``; one that fails is skipped (strict: error)."""
    from dance_core.plugins import get_plugin_manager, plugin_failure

    pm = get_plugin_manager()
    for impl in pm.hook.register_commands.get_hookimpls():
        try:
            impl.function(subparsers=sub)
        except BaseException as exc:
            if isinstance(exc, DanceError) or impl.plugin_name in DEFAULT_PLUGINS:
                raise
            why = plugin_failure(exc, f"plugin {impl.plugin_name!r} in register_commands")
            pm.skip(impl.plugin_name, f"failed in register_commands: {why}")


def _compose_parser(sub) -> None:
    p = sub.add_parser(
        "compose",
        help="write dances for songs with a trained model",
        description="Compose a dance for each song with a recipe's trained model; prints each written file, "
        "one per line, then a summary line on stderr (--json: one JSON summary on stdout instead). A folder "
        "stands for its audio files; a song whose files are all in the output folder already is skipped "
        "(--overwrite to redo it); --shard I/N composes every N-th song of the list sorted by path, starting "
        "at the I-th, so N machines or job-array tasks share a catalogue with no coordination.",
        epilog=_examples(
            "dance compose default --music song.ogg -o out",
            "dance compose core-synthetic --checkpoint runs/demo/model.safetensors --music a.wav b.wav --json",
            "dance compose default --music songs/ -o out --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT",
        ),
    )
    p.add_argument("recipe", help="recipe file or bundled recipe name (dance recipe list)").completer = _recipes
    p.add_argument("--music", nargs="+", metavar="SONG|FOLDER",
                   help="songs to dance to, or folders of them (default: compose.music)")
    p.add_argument("--checkpoint", help="model checkpoint (default: compose.checkpoint)")
    p.add_argument("-o", "--out", metavar="DIR", help="output folder (default: compose.out_dir)")
    p.add_argument("--samples", type=bounded_number(int, 1, 1000), metavar="N",
                   help="dances per song, 1-1000 (default: compose.samples)")
    p.add_argument("--temperature", type=bounded_number(float, 0.0),
                   help="sampling temperature, 0 = most likely; above 3 the dance is chaotic "
                   "(default: compose.temperature)")
    p.add_argument("--seconds", type=bounded_number(float, 0.0, 3600.0, above=True, unit="s"),
                   help="length of each dance in seconds, up to 3600 (default: the whole song)")
    p.add_argument("--start", type=bounded_number(float, 0.0, unit="s"), metavar="SECONDS",
                   help="compose from this time in the song on (default: compose.start, 0); --text spans stay in "
                        "the song's time")
    p.add_argument("--seed-motion", metavar="FILE", help="motion file to start from, or 'rest'")
    smpl_model_option(p)
    p.add_argument("--format", dest="formats", action="append", metavar="NAME",
                   help="output format, e.g. bvh, npz, html, gif (repeatable; default: compose.formats)")
    p.add_argument("--text", dest="texts", action="append", metavar="[START-END:] TEXT",
                   help='text instruction, e.g. "20-30: a person jumps" (seconds; no span: the whole song; '
                        "repeatable; models that read text only)")
    p.add_argument("--markers", action="store_true", default=None,
                   help="also write each dance's .markers.json: the song's beats, downbeats, sections and the "
                        "foot contacts (default: compose.markers)")
    p.add_argument("--rig", metavar="RIG", help="retarget each dance onto your character: a .bvh or .glb whose "
                   "skeleton is the rig, or dance24 (default: compose.rig)")
    p.add_argument("--rig-map", metavar="MAP", help="joint map of the rig: a preset name or a YAML file "
                   "(default: detected)")
    p.add_argument("--fps", dest="output_fps", type=bounded_number(float, 0.0, 1000.0, above=True),
                   help="frame rate of the files written, e.g. 24, 30, 60 (resampled; default: the model's)")
    p.add_argument("--units", choices=("m", "cm"), help="length units of the files written (glb: always m)")
    p.add_argument("--up", choices=("y", "z"), help="up axis of the files written: z for Z-up tools (bvh and npz; "
                   "glb is always Y up, as glTF 2.0 says; default: compose.up)")
    p.add_argument("--keyframe", dest="keyframes", action="append", metavar="T=POSE[:FRAME]",
                   help="pass through frame FRAME (default 0) of the motion file POSE at T seconds (repeatable)")
    p.add_argument("--keep", dest="keep_parts", action="append", metavar="PART=MOTION",
                   help="take a body part (legs, arms, upper, lower, root) from a motion file (repeatable)")
    p.add_argument("--face", choices=("free", "camera"), help="camera: keep facing +Z (default: compose.face)")
    p.add_argument("--max-turn", type=bounded_number(float, 0.0, above=True), metavar="DEG_PER_S",
                   help="limit on turning speed in degrees per second")
    p.add_argument("--loop", action="store_true", default=None, help="the last frame leads into the first")
    p.add_argument("--from", dest="from_motion", metavar="DANCE",
                   help="a dance to edit: --regenerate its spans, keep every other frame")
    p.add_argument("--regenerate", action="append", metavar="START-END",
                   help="a span of --from's dance to generate again, in seconds (repeatable)")
    p.add_argument("--shard", type=shard_arg, metavar="I/N",
                   help="compose only part I of N (1-based): song k (from 0) of the path-sorted list goes to part "
                        "k mod N + 1")
    p.add_argument("--overwrite", action="store_true",
                   help="compose songs whose output files all exist already (default: skip them)")
    p.add_argument("--keep-going", action="store_true",
                   help="a song that fails (unreadable, an implausible dance) is listed at the end and the others "
                        "are written; exit code 1 when any failed")
    p.add_argument("--json", action="store_true", help="print one JSON summary instead of the file names")
    _sets(p)
    p.set_defaults(run=commands.compose)


def _train_parser(sub) -> None:
    p = sub.add_parser(
        "train",
        help="train a recipe's model",
        description="Train a recipe's model into a run folder (model.safetensors, training state, log, recipe). "
        "Under torchrun, every process trains its share of each batch (DistributedDataParallel; "
        "training.batch_size is per process) and rank 0 writes the run folder.",
        epilog=_examples(
            "dance train core-synthetic --out runs/demo --set training.steps=200",
            "dance train core-synthetic --out runs/demo --resume",
            "dance train core-synthetic --out runs/demo --nproc-per-node 2",
            "torchrun --nproc_per_node=4 $(which dance) train core-synthetic --out runs/demo",
        ),
    )
    p.add_argument("recipe", help="recipe file or bundled recipe name (dance recipe list)").completer = _recipes
    p.add_argument("-o", "--out", metavar="DIR", help="run folder (default: training.output)")
    p.add_argument("--resume", action="store_true", help="continue the run in the run folder")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a run already in the run folder (default: refuse to)")
    p.add_argument("--stop-at", type=bounded_number(int, 1), metavar="STEP",
                   help="checkpoint and stop at this step (1 to the recipe's total steps)")
    p.add_argument("--nproc-per-node", type=bounded_number(int, 1, 1024), metavar="N",
                   help="train on N processes of this machine through torch's launcher, as torchrun "
                   "--standalone --nproc-per-node N does (one per GPU; gloo on CPU)")
    smpl_model_option(p)
    _sets(p)
    p.set_defaults(run=commands.train)


def _recipe_parsers(sub) -> None:
    rp = sub.add_parser(
        "recipe",
        help="validate, show, list recipes or print their schema",
        epilog=_examples("dance recipe list", "dance recipe validate my-recipe.yaml"),
    )
    rsub = rp.add_subparsers(dest="recipe_command", metavar="ACTION", parser_class=Parser, required=True)
    for name, fn, text, example in (
        ("validate", commands.recipe_validate, "check a recipe and its components' options",
         "dance recipe validate my-recipe.yaml --set training.steps=100"),
        ("show", commands.recipe_show, "print the resolved recipe", "dance recipe show core-synthetic"),
    ):
        p = rsub.add_parser(name, help=text, description=text[:1].upper() + text[1:] + ".",
                            epilog=_examples(example))
        arg = p.add_argument("recipe", help="recipe file or bundled recipe name (dance recipe list)")
        arg.completer = _recipes
        _sets(p)
        p.set_defaults(run=fn)
    p = rsub.add_parser("schema", help="print the JSON Schema of recipes",
                        epilog=_examples("dance recipe schema -o recipe.schema.json"))
    p.add_argument("-o", "--out", metavar="FILE", help="write to a file instead of stdout")
    p.set_defaults(run=commands.recipe_schema)
    p = rsub.add_parser("list", help="list bundled recipes", epilog=_examples("dance recipe list --json"))
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=commands.recipe_list)


def _recipes(prefix: str = "", **_) -> list[str]:
    """Bundled recipe names (and YAML files here) for tab completion."""
    from pathlib import Path

    from dance_core.registry import get_registry

    return [*get_registry().names("recipe"), *(str(p) for p in Path(".").glob(f"{prefix}*.y*ml"))]


class _Completion(argparse.Action):
    """``--install-completion``: argcomplete's shell code for ``dance`` on stdout, then exit."""

    def __call__(self, parser, namespace, values, option_string=None):  # noqa: D102
        try:
            import argcomplete
        except ImportError:
            parser.exit(1, "dance: error: --install-completion: argcomplete is not installed "
                           "(pip install 'dance-core[completion]')\n")
        sys.stdout.write(argcomplete.shellcode(["dance"]))
        parser.exit(0)


def build_parser() -> Parser:
    """The full argument parser (plugins may add subcommands through ``register_commands``)."""
    from importlib.metadata import version

    parser = Parser(
        prog="dance",
        description="Music (and text) to 3D dance motion.",
        epilog=_examples(
            "dance compose default --music song.ogg -o out",
            "dance COMMAND --help",
        ),
    )
    parser.add_argument("--version", action="version", version=f"dance {version('dance-core')}")
    parser.add_argument("--install-completion", action=_Completion, nargs=0,
                        help="print bash/zsh completion for dance (needs dance-core[completion]); "
                             "add it with: eval \"$(dance --install-completion)\"")
    for flags, text in COMMON_FLAGS:
        parser.add_argument(*flags, action="store_true", help=text)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    _compose_parser(sub)
    _train_parser(sub)
    p = sub.add_parser("plugins", help="list installed components by kind",
                       epilog=_examples("dance plugins", "dance plugins --json"))
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=commands.plugins)
    _plugin_commands(sub)
    _recipe_parsers(sub)
    _add_common_flags(parser)
    return parser


def describe(exc: BaseException) -> str:
    """One line for an unexpected ``OSError``/``ValueError``/``MemoryError``, naming its file when it has one."""
    return describe_error(exc)


def _interrupt_code(exc: BaseException | None) -> int:
    """The exit code of an interrupt (130; 143 for SIGTERM), or 0 when ``exc`` is none."""
    from dance_core.atomic import Terminated

    if not isinstance(exc, KeyboardInterrupt):
        return 0
    return 143 if isinstance(exc, Terminated) else 130


#: commands that stream on standard output while they run and print their own ``--json`` summary (``dance live
#: --output -``: frames as JSON Lines on stdout, the summary on stderr), so stdout is not captured for them
OWN_JSON = frozenset({"live"})


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``dance`` script; with ``--json`` (any command) one JSON object on stdout, errors
    included: a command's own JSON as it prints it, else ``{"output": [lines]}``; on an error ``"error"`` (its
    line) and ``"exit_code"``, the exit code kept. Warnings and progress stay on stderr."""
    args = sys.argv[1:] if argv is None else argv
    if "--json" not in args or next((a for a in args if not a.startswith("-")), None) in OWN_JSON:
        return _main(argv)
    out, err = io.StringIO(), _Tee(sys.stderr)
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = _main(argv)
        except SystemExit as exc:  # a usage error (2), --help or --version (0)
            code = exc.code if isinstance(exc.code, int) else 1
    text = out.getvalue()
    try:
        data, native = json.loads(text), True
    except ValueError:
        data, native = {"output": text.splitlines()}, False
    if code == 0 and native:
        sys.stdout.write(text)  # the command's own JSON, unchanged
        return code
    if code != 0:
        data = data if isinstance(data, dict) else {"output": data}
        seen = err.seen.strip().splitlines()
        errors = [line.split(": error: ", 1)[1] for line in seen if ": error: " in line]
        data.setdefault("error", "; ".join(errors) if errors else (seen[-1] if seen else f"exit code {code}"))
        data["exit_code"] = code
    print(json.dumps(data, indent=2))
    return code


class _Tee(io.TextIOBase):
    """stderr as it is, also kept (``seen``) for ``--json``'s error line."""

    def __init__(self, stream) -> None:
        self.stream, self.seen = stream, ""

    def write(self, text: str) -> int:  # noqa: D102
        self.seen += text
        return self.stream.write(text)

    def flush(self) -> None:  # noqa: D102
        self.stream.flush()

    def isatty(self) -> bool:  # noqa: D102
        return self.stream.isatty()


def _main(argv: list[str] | None = None) -> int:
    """``dance`` without ``--json``'s wrapping."""
    if "--strict" in (sys.argv[1:] if argv is None else argv):
        os.environ[ENV_STRICT] = "1"  # read when the plugin manager is built, before parsing
        from dance_core import plugins, registry

        plugins.get_plugin_manager.cache_clear()
        registry.reset()
    try:
        parser = build_parser()
    except DanceError as exc:  # a broken plugin: still one line
        print(f"dance: error: {exc}", file=sys.stderr)
        return _interrupt_code(exc.__cause__) or 1
    with contextlib.suppress(ImportError):  # tab completion (dance-core[completion]): acts only when the shell asks
        import argcomplete

        argcomplete.autocomplete(parser)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    if argv is None:  # the ``dance`` process itself: SIGTERM cleans up like Ctrl-C for the whole command
        from dance_core.atomic import install_sigterm_handler

        install_sigterm_handler()
    try:
        use_smpl_model(args)  # --smpl-model, on the commands that read motion files
        return args.run(args) or 0
    except DanceError as exc:
        if args.debug:
            raise
        for line in str(exc).splitlines() or [type(exc).__name__]:
            print(f"dance: error: {line}", file=sys.stderr)
        return _interrupt_code(exc.__cause__) or 1
    except BrokenPipeError:  # output piped into head, less...: stop quietly
        sys.stderr.close()
        return 0
    except KeyboardInterrupt as exc:
        code = _interrupt_code(exc)
        print(f"dance: {'terminated' if code == 143 else 'interrupted'}", file=sys.stderr)
        return code
    except (OSError, ValueError, MemoryError) as exc:  # not foreseen by a check: still one line
        if args.debug:
            raise
        print(f"dance: error: {describe(exc)} (--debug shows the traceback)", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
