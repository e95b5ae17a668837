"""``dance``: argument parsing and error reporting; each command lives in its own small module."""

from __future__ import annotations

import argparse
import os
import sys

from dance_core.cli import commands
from dance_core.errors import DanceError
from dance_core.plugins import DEFAULT_PLUGINS, ENV_STRICT


class Parser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line on stderr, exit code 2."""

    def error(self, message: str):  # noqa: D102 - argparse hook
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _sets(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--set",
        dest="sets",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="override a recipe field, e.g. --set training.steps=100",
    )


def _plugin_commands(sub) -> None:
    """Subcommands from every plugin's ``register_commands``; one that fails is skipped (strict: error)."""
    from dance_core.plugins import get_plugin_manager

    pm = get_plugin_manager()
    for impl in pm.hook.register_commands.get_hookimpls():
        try:
            impl.function(subparsers=sub)
        except Exception as exc:
            if isinstance(exc, DanceError) or impl.plugin_name in DEFAULT_PLUGINS:
                raise
            pm.skip(impl.plugin_name, f"failed in register_commands: {type(exc).__name__}: {exc}")


def build_parser() -> Parser:
    """The full argument parser (plugins may add subcommands through ``register_commands``)."""
    from importlib.metadata import version

    parser = Parser(prog="dance", description="Music (and text) to 3D dance motion.")
    parser.add_argument("--version", action="version", version=f"dance {version('dance-core')}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks for errors")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    parser.add_argument(
        "--strict", action="store_true", help=f"stop on a broken plugin instead of skipping it ({ENV_STRICT}=1)"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)

    p = sub.add_parser("compose", help="write dances for songs with a trained model")
    p.add_argument("recipe", help="recipe file or bundled recipe name")
    p.add_argument("--music", nargs="+", help="songs to dance to (default: compose.music)")
    p.add_argument("--checkpoint", help="model checkpoint (default: compose.checkpoint)")
    p.add_argument("-o", "--out", help="output folder (default: compose.out_dir)")
    p.add_argument("--samples", type=int, help="dances per song")
    p.add_argument("--temperature", type=float, help="sampling temperature")
    p.add_argument("--seconds", type=float, help="length of each dance in seconds")
    p.add_argument("--seed-motion", help="motion file to start from, or 'rest'")
    p.add_argument("--format", dest="formats", action="append", help="output format (repeatable)")
    p.add_argument("--text", dest="texts", action="append", metavar="[START-END:] TEXT",
                   help='text instruction, e.g. "20-30: a person jumps" (seconds; no span: the whole song; '
                        "repeatable; models that read text only)")
    _sets(p)
    p.set_defaults(run=commands.compose)

    p = sub.add_parser("train", help="train a recipe's model")
    p.add_argument("recipe", help="recipe file or bundled recipe name")
    p.add_argument("-o", "--out", help="run folder (default: training.output)")
    p.add_argument("--resume", action="store_true", help="continue the run in the run folder")
    p.add_argument("--stop-at", type=int, metavar="STEP", help="checkpoint and stop at this step")
    _sets(p)
    p.set_defaults(run=commands.train)

    p = sub.add_parser("synth", help="write a click-track test song, or (--out DIR) a synthetic dance dataset")
    p.add_argument("out", nargs="?", help="WAV file to write (a click track)")
    p.add_argument("--out", dest="out_dir", metavar="DIR",
                   help="write a dataset instead: songs with a beat-locked SMPL dancer (WAV, BVH, beats, labels)")
    p.add_argument("--songs", type=int, default=10, help="dataset songs (default 10)")
    p.add_argument("--music", nargs="+", metavar="SONG",
                   help="with --out: choreograph the dancer to these songs (files or folders) instead")
    p.add_argument("--dances", type=int, default=1, help="with --music: dances per song (default 1)")
    p.add_argument("--tracker", choices=["librosa", "madmom", "auto"], default="librosa",
                   help="with --music: beat tracker (default librosa; madmom's model files are non-commercial)")
    p.add_argument("--fps", type=float, default=60.0, help="dataset motion frame rate (default 60)")
    p.add_argument("--jobs", type=int, default=1, help="dataset worker processes (default 1)")
    p.add_argument("--bpm", type=float, default=120.0, help="click-track tempo (default 120)")
    p.add_argument("--seconds", type=float, help="length (default 20 for a click track, 60 for dataset songs)")
    p.add_argument("--rate", type=int, default=22050, help="sample rate (default 22050)")
    p.add_argument("--seed", type=int, default=0, help="seed of the drone notes and noise")
    p.set_defaults(run=commands.synth)

    p = sub.add_parser("plugins", help="list installed components by kind")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=commands.plugins)

    _plugin_commands(sub)

    rp = sub.add_parser("recipe", help="validate, show, list recipes or print their schema")
    rsub = rp.add_subparsers(dest="recipe_command", metavar="ACTION", parser_class=Parser, required=True)
    for name, fn, text in (
        ("validate", commands.recipe_validate, "check a recipe and its components' options"),
        ("show", commands.recipe_show, "print the resolved recipe"),
    ):
        p = rsub.add_parser(name, help=text)
        p.add_argument("recipe", help="recipe file or bundled recipe name")
        _sets(p)
        p.set_defaults(run=fn)
    p = rsub.add_parser("schema", help="print the JSON Schema of recipes")
    p.add_argument("-o", "--out", help="write to a file instead of stdout")
    p.set_defaults(run=commands.recipe_schema)
    p = rsub.add_parser("list", help="list bundled recipes")
    p.set_defaults(run=commands.recipe_list)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``dance`` script."""
    if "--strict" in (sys.argv[1:] if argv is None else argv):
        os.environ[ENV_STRICT] = "1"  # read when the plugin manager is built, before parsing
        from dance_core import plugins, registry

        plugins.get_plugin_manager.cache_clear()
        registry.reset()
    try:
        parser = build_parser()
    except DanceError as exc:  # a broken plugin: still one line
        print(f"dance: error: {exc}", file=sys.stderr)
        return 1
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return args.run(args) or 0
    except DanceError as exc:
        if args.debug:
            raise
        for line in str(exc).splitlines() or [type(exc).__name__]:
            print(f"dance: error: {line}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # output piped into head, less...: stop quietly
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print("dance: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
