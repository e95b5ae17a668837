"""The ``dance`` subcommands (heavy imports stay inside each function)."""

from __future__ import annotations

import json
import sys
import time
from argparse import Namespace
from pathlib import PurePath

from dance_core.progress import say


def _recipe(args: Namespace, extra: list[str] = ()):
    from dance_core.recipe import load_recipe

    return load_recipe(args.recipe, [*args.sets, *extra])


def compose(args: Namespace) -> int:
    """``dance compose``: check every input and the output folder, compose, print the files and a summary."""
    from dance_core import api

    texts = [_text(t) for t in args.texts] if args.texts else None  # a bad --text stops before the recipe loads
    recipe = _recipe(args)
    options = api.ComposeOptions(
        music=args.music, checkpoint=args.checkpoint, out_dir=args.out, samples=args.samples,
        seconds=args.seconds, start=args.start, temperature=args.temperature, seed_motion=args.seed_motion, texts=texts,
        formats=args.formats, markers=args.markers, rig=args.rig, rig_map=args.rig_map, output_fps=args.output_fps,
        units=args.units, up=args.up, keyframes=args.keyframes, keep_parts=_parts(args.keep_parts), face=args.face,
        max_turn=args.max_turn, loop=args.loop, from_motion=args.from_motion, regenerate=args.regenerate,
        overwrite=args.overwrite, shard=args.shard, quiet=args.quiet, keep_going=args.keep_going,
    )
    inputs = api.resolve_inputs(recipe, options)
    _check_compose_inputs(inputs)
    start = time.perf_counter()
    result = api.compose(inputs)
    wall = time.perf_counter() - start
    summary = _compose_summary(inputs.recipe, result, inputs.out_dir, wall)
    failed = f"{len(result.failed)} song(s) failed, the others written" if result.failed else None
    if args.json:
        print(json.dumps({**summary, **({"error": failed} if failed else {})}, indent=2))
        return 1 if failed else 0
    say(args, *summary["files"])
    if not args.quiet:
        print(_compose_line(summary), file=sys.stderr)
    for song, why in result.failed:  # --keep-going: listed at the end, one line each
        print(f"dance: error: {why if why.startswith(str(song)) else f'{song}: {why}'}", file=sys.stderr)
    if failed:
        print(f"dance: error: {failed} (--keep-going)", file=sys.stderr)
    return 1 if failed else 0


#: the command-line option that gives each composition input (else it comes from the recipe's compose:)
_OPTIONS = {"music": "--music", "checkpoint": "--checkpoint", "seed_motion": "--seed-motion", "out_dir": "-o",
            "temperature": "--temperature"}


def _where(inputs, name: str) -> str:
    """The option an input came from, or its recipe field."""
    return _OPTIONS[name] if inputs.options.given(name) else f"compose.{name}"


def _check_compose_inputs(inputs) -> None:
    """The songs and checkpoint compose will read, and the folder it will write, checked before any work."""
    from dance_core.checks import check_input_file, check_output_dir, refuse_same_names
    from dance_core.cli.checks import check_smpl_model, warn

    where = _where(inputs, "music")
    songs = [song for music in inputs.music for song in music.songs(where)]  # a folder without songs: one line
    refuse_same_names(songs, where)  # a/song.wav and b/song.wav would write one set of files
    for song in songs:
        check_input_file(song, where, "audio file")  # an empty file stops before any work
    if inputs.checkpoint is not None:
        check_input_file(inputs.checkpoint, _where(inputs, "checkpoint"), "checkpoint", in_folder="model.safetensors")
    if inputs.seed_motion not in (None, "rest"):  # as given, else beside the recipe (as compose reads it)
        seed = check_input_file(inputs.seed_motion, _where(inputs, "seed_motion"), "motion file")
        # an AIST++ seed without its SMPL model (formats.smpl.model or --smpl-model) stops before the model loads
        check_smpl_model([seed], inputs.recipe.format_options)
    check_output_dir(inputs.out_dir, _where(inputs, "out_dir"))
    temperature = inputs.recipe.compose.temperature
    if temperature > TEMPERATURE_WARN:
        warn(f"{_where(inputs, 'temperature')} {temperature:g} is far above 1: the dance will be chaotic "
             "(try 0.5 to 1.5)")


#: above this sampling temperature ``dance compose`` warns that the dance will be chaotic
TEMPERATURE_WARN = 3.0


def _compose_summary(recipe, result, out: str, wall: float) -> dict:
    """Songs (this shard's; written and skipped), seconds and frames of dance generated, files written (the
    dances, then their sidecars) and frames composed per second of wall time (model loading and writing
    included)."""
    frames = result.frames
    return {
        "songs": [str(s) for s in result.songs],
        "written_songs": [str(s) for s in result.songs
                          if s not in set(result.skipped) and s not in {f for f, _ in result.failed}],
        "skipped_songs": [str(s) for s in result.skipped],
        "shard": str(result.shard) if result.shard else None,
        "samples": recipe.compose.samples,
        "seconds": round(result.seconds, 3) if frames else None,
        "frames": frames if frames else None,
        "files": [str(p) for p in [*result.written, *result.sidecars]],
        "out": str(out),
        "wall_seconds": round(wall, 3),
        "frames_per_second": round(frames / wall, 1) if frames and wall > 0 else None,
        "failed_songs": [{"song": str(song), "error": why} for song, why in result.failed],
    }


def _compose_line(summary: dict) -> str:
    """The summary line ``dance compose`` prints on stderr."""
    seconds = "0.0" if summary["seconds"] is None else f"{summary['seconds']:.1f}"
    rate = "" if summary["frames_per_second"] is None else f", {summary['frames_per_second']:.0f} frames/s"
    line = (f"composed {len(summary['written_songs'])} song(s) x {summary['samples']}: {seconds} s of dance, "
            f"{len(summary['files'])} file(s){_kinds(summary['files'])} in {summary['out']}{rate}")
    if summary["skipped_songs"]:
        line += f"; {len(summary['skipped_songs'])} song(s) skipped, already complete (--overwrite to redo)"
    if summary["shard"]:
        line += f"; shard {summary['shard']} holds {len(summary['songs'])} song(s)"
    return line


def _kinds(files: list[str]) -> str:
    """`` (2 .bvh, 2 .html, 2 .markers.json)``: the files by kind, when there are several kinds."""
    from collections import Counter

    from dance_core.motion.markers import SIDECAR

    kinds = Counter(SIDECAR if f.endswith(SIDECAR) else PurePath(f).suffix for f in files)
    return "" if len(kinds) < 2 else f" ({', '.join(f'{n} {kind}' for kind, n in kinds.items())})"


def _parts(given: list[str] | None) -> dict[str, str] | None:
    """``--keep PART=MOTION`` options as a mapping; a malformed or repeated part is one line."""
    from dance_core.errors import RecipeError

    if not given:
        return None
    parts: dict[str, str] = {}
    for spec in given:
        part, sep, path = spec.partition("=")
        if not sep or not part.strip() or not path.strip():
            raise RecipeError(f"--keep {spec!r}: expected PART=MOTION_FILE, e.g. legs=walk.bvh")
        if part.strip() in parts:
            raise RecipeError(f"--keep {part.strip()}: given twice")
        parts[part.strip()] = path.strip()
    return parts


def _text(given: str):
    """One ``--text`` as a TextSpec, or a one-line error naming it."""
    from pydantic import ValidationError

    from dance_core.errors import RecipeError
    from dance_core.recipe.schema import TextSpec

    try:
        return TextSpec.parse(given)
    except ValueError as exc:  # a malformed span, or a pydantic ValidationError
        msg = exc.errors()[0]["msg"].removeprefix("Value error, ") if isinstance(exc, ValidationError) else str(exc)
        raise RecipeError(f"--text {given!r}: {msg}") from None


def train(args: Namespace) -> int:
    """``dance train``: check ``--stop-at`` and the run folder, then train (``--nproc-per-node N``:
    relaunch this command on N processes through torch's launcher; under torchrun, rank 0 alone
    prints, and an error every rank stopped with is printed once)."""
    import os

    from dance_core import api
    from dance_core.checks import check_output_dir
    from dance_core.errors import DanceError

    nproc = getattr(args, "nproc_per_node", None)
    if nproc is not None and "RANK" in os.environ:
        raise DanceError("--nproc-per-node: this process was already started by torchrun; give one or the other")
    if "RANK" in os.environ and os.environ.get("RANK") != "0":
        args.quiet = True
    recipe = _recipe(args)
    stages = recipe.training.stage_list()
    total = sum(s.steps for s in stages)
    if args.stop_at is not None and args.stop_at > total:
        field = "training.stages" if recipe.training.stages else "training.steps"
        raise DanceError(f"--stop-at {args.stop_at}: the run has {total} steps ({field}); give 1 to {total}")
    if args.resume and args.overwrite:
        raise DanceError("--resume and --overwrite: give one (continue the run in the folder, or replace it)")
    options = api.TrainOptions(out=args.out, resume=args.resume, stop_at=args.stop_at, quiet=args.quiet,
                               overwrite=args.overwrite)
    run_dir = api.run_dir(recipe, options)
    option = "-o" if args.out else "training.output"
    check_output_dir(run_dir, option)
    if args.resume and not run_dir.is_dir():
        raise DanceError(f"--resume: {option} {run_dir}: run folder not found; nothing to resume")
    if not args.resume and not args.overwrite:
        from dance_core.train import refuse_existing_run

        refuse_existing_run(run_dir, option)  # before any work; checked again under the run's lock
    if nproc is not None:
        from dance_core.distributed import launch

        return launch(_train_argv(args), nproc)
    try:
        result = api.train(recipe, options)
    except DanceError as exc:
        if os.environ.get("RANK", "0") != "0" and getattr(exc, "all_ranks", False):
            raise SystemExit(1) from None  # every rank stopped with this message: rank 0 prints it, once
        raise
    if os.environ.get("RANK", "0") != "0":
        return 0
    val = f", validation loss {result.val_loss:.4f}" if result.val_loss is not None else ""
    say(args, f"trained {result.steps} steps: loss {result.first_loss:.4f} -> {result.last_loss:.4f}{val}",
        str(result.checkpoint))
    return 0


def _train_argv(args: Namespace) -> list[str]:
    """The ``dance`` arguments each launched process runs: this ``train`` command without ``--nproc-per-node``."""
    argv = [flag for flag, on in (("--debug", args.debug), ("--quiet", args.quiet), ("--strict", args.strict)) if on]
    argv += ["train", args.recipe]
    if args.out:
        argv += ["--out", args.out]
    if args.resume:
        argv.append("--resume")
    if args.overwrite:
        argv.append("--overwrite")
    if args.stop_at is not None:
        argv += ["--stop-at", str(args.stop_at)]
    for value in args.sets:
        argv += ["--set", value]
    return argv


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
    say(args, f"{recipe.origin}: ok ({recipe.name}: {parts})")  # -q: the exit code alone
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

    if args.out:
        from dance_core.checks import check_output_file

        check_output_file(args.out, "-o")
    text = json.dumps(recipe_json_schema(get_registry()), indent=2) + "\n"
    if args.out:
        write_text(args.out, text)
    else:
        sys.stdout.write(text)
    return 0


def recipe_list(args: Namespace) -> int:
    """``dance recipe list``: name, distribution and description of each bundled recipe (``--json``: with paths)."""
    from dance_core.registry import get_registry

    entries = get_registry().entries("recipe")
    if args.json:
        data = [{"name": e.name, "distribution": e.distribution, "version": e.version,
                 "description": e.description, "path": str(e.target)} for e in entries]
        print(json.dumps(data, indent=2))
        return 0
    for e in entries:
        print(f"{e.name:24} {e.distribution:12} {e.description}")
    return 0

