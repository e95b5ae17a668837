"""The ``dance`` subcommands (heavy imports stay inside each function)."""

from __future__ import annotations

import json
import sys
from argparse import Namespace


def _recipe(args: Namespace, extra: list[str] = ()):
    from dance_core.recipe import load_recipe

    return load_recipe(args.recipe, [*args.sets, *extra])


def compose(args: Namespace) -> int:
    """``dance compose``."""
    from dance_core.compose import compose as run

    extra = []
    for field, value in (
        ("samples", args.samples),
        ("temperature", args.temperature),
        ("seconds", args.seconds),
        ("seed_motion", args.seed_motion),
    ):
        if value is not None:
            extra.append(f"compose.{field}={value}")
    if args.formats:
        extra.append(f"compose.formats={json.dumps(args.formats)}")
    if args.texts:
        extra.append(f"compose.texts={json.dumps([_text(t).model_dump() for t in args.texts])}")
    recipe = _recipe(args, extra)
    written = run(recipe, music=args.music, checkpoint=args.checkpoint, out_dir=args.out, quiet=args.quiet)
    for path in written:
        print(path)
    return 0


def _text(given: str):
    """One ``--text`` as a TextSpec, or a one-line error naming it."""
    from pydantic import ValidationError

    from dance_core.errors import RecipeError
    from dance_core.recipe.schema import TextSpec

    try:
        return TextSpec.parse(given)
    except ValidationError as exc:
        msg = exc.errors()[0]["msg"].removeprefix("Value error, ")
        raise RecipeError(f"--text {given!r}: {msg}") from None


def train(args: Namespace) -> int:
    """``dance train``."""
    from dance_core.train import train as run

    result = run(_recipe(args), out=args.out, resume=args.resume, quiet=args.quiet, stop_at=args.stop_at)
    val = f", validation loss {result.val_loss:.4f}" if result.val_loss is not None else ""
    print(f"trained {result.steps} steps: loss {result.first_loss:.4f} -> {result.last_loss:.4f}{val}")
    print(result.checkpoint)
    return 0


def plugins(args: Namespace) -> int:
    """``dance plugins``: every component by kind, with its plugin and version."""
    from rich.console import Console
    from rich.table import Table

    from dance_core.plugins import get_plugin_manager
    from dance_core.registry import KINDS, get_registry

    registry = get_registry()
    broken = get_plugin_manager().broken
    if args.json:
        data = {
            kind: [
                {
                    "name": e.name,
                    "plugin": e.plugin,
                    "distribution": e.distribution,
                    "version": e.version,
                    "description": e.description,
                }
                for e in registry.entries(kind)
            ]
            for kind in KINDS
        }
        data["broken"] = [{"plugin": b.name, "distribution": b.distribution, "reason": b.reason} for b in broken]
        print(json.dumps(data, indent=2))
        return 0
    rows = [(kind, e.name, e.plugin, e.distribution, e.version, e.description)
            for kind in KINDS for e in registry.entries(kind)]
    rows += [("BROKEN", "", b.name, b.distribution, "", b.reason) for b in broken]
    if not sys.stdout.isatty():  # a pipe or a file: every column whole, tab-separated
        for row in [("kind", "name", "plugin", "distribution", "version", "description"), *rows]:
            print("\t".join(row))
        return 0
    table = Table(title="dance components")
    for column in ("kind", "name", "plugin", "distribution", "version"):
        table.add_column(column, no_wrap=True)
    table.add_column("description", overflow="fold")
    for row in rows:
        table.add_row(*row)
    Console().print(table)
    return 0


def recipe_validate(args: Namespace) -> int:
    """``dance recipe validate``."""
    recipe = _recipe(args)
    parts = ", ".join(f"{kind} {spec.plugin}" for kind, _, spec in recipe.components())
    print(f"{recipe._origin}: ok ({recipe.name}: {parts})")
    return 0


def recipe_show(args: Namespace) -> int:
    """``dance recipe show``: the resolved recipe as YAML."""
    import yaml

    data = _recipe(args).model_dump(mode="json", exclude={"extends"})
    sys.stdout.write(yaml.safe_dump(data, sort_keys=False))
    return 0


def recipe_schema(args: Namespace) -> int:
    """``dance recipe schema``."""
    from dance_core.atomic import write_text
    from dance_core.recipe.jsonschema import recipe_json_schema
    from dance_core.registry import get_registry

    text = json.dumps(recipe_json_schema(get_registry()), indent=2) + "\n"
    if args.out:
        write_text(args.out, text)
    else:
        sys.stdout.write(text)
    return 0


def recipe_list(args: Namespace) -> int:
    """``dance recipe list``."""
    from dance_core.registry import get_registry

    for e in get_registry().entries("recipe"):
        print(f"{e.name:24} {e.distribution:12} {e.description}")
    return 0


def synth(args: Namespace) -> int:
    """``dance synth``: a click track with beats every 60/bpm seconds (downbeat every 4th)."""
    import numpy as np

    from dance_core.components.synthetic import click_track
    from dance_core.components.wav import write_wav
    from dance_core.errors import DanceError

    if args.music and args.out_dir is None:
        raise DanceError("synth: --music needs --out DIR (the folder to write the dances into)")
    if args.out_dir is not None:
        from dance_core.data.synthetic_dance import synth_command

        return synth_command(args)
    if args.out is None:
        raise DanceError("synth: give a WAV file to write, or --out DIR for a synthetic dance dataset")
    seconds = 20.0 if args.seconds is None else args.seconds
    if not (20 <= args.bpm <= 400) or not (0.5 <= seconds <= 3600) or args.rate < 4000:
        raise DanceError("synth: need 20 <= --bpm <= 400, 0.5 <= --seconds <= 3600, --rate >= 4000")
    beats = np.arange(0.0, seconds, 60.0 / args.bpm)
    audio = click_track(beats, seconds, args.rate, np.random.default_rng(args.seed))
    write_wav(args.out, audio, args.rate)
    print(args.out)
    return 0
