"""``dance evaluate``: score generated dances against reference dances (and their music).

Registered through core's ``register_commands`` hook; everything heavy is imported in ``run``.
"""

from __future__ import annotations

import argparse

from dance_core.checks import bounded_number
from dance_core.cli.checks import smpl_model_option


def add_parser(subparsers) -> None:
    """Add the ``evaluate`` subcommand."""
    p = subparsers.add_parser(
        "evaluate",
        help="score generated dances against reference dances (FID, BAS, freezing...)",
        description="Score a folder of generated motion files against a folder of reference motion "
        "files with the registered metrics; writes a JSON report and plots (--json: the report on stdout too).",
        epilog="examples:\n"
        "  dance evaluate --generated out --reference data/test --music data/test -o report.json\n"
        "  dance evaluate --generated out --reference data/test --metrics fid-k fid-g --no-plots --json",
    )
    p.add_argument("--generated", required=True, metavar="DIR", help="folder of generated motion files")
    p.add_argument("--reference", required=True, metavar="DIR", help="folder of reference (real) motion files")
    p.add_argument(
        "--music", metavar="DIR", help="folder of the songs (audio or NAME.beats) named like the motion files"
    )
    p.add_argument("--tracker", choices=("flux", "librosa", "madmom", "auto"), default="flux",
                   help="beat tracker for songs without a .beats file (default flux: licence-clean; madmom reads "
                   "non-commercial weights)")
    p.add_argument("--metrics", nargs="+", metavar="NAME", help="metrics to compute (default: all registered)")
    p.add_argument("-o", "--out", default="report.json", metavar="FILE", help="JSON report to write")
    p.add_argument("--plots", metavar="DIR", help="folder for the figures (default: next to the report)")
    p.add_argument("--no-plots", action="store_true", help="write no figures")
    p.add_argument("--plot-clips", type=bounded_number(int, 0, 1000), default=4, metavar="N",
                   help="beat figures for N clips")
    p.add_argument(
        "--compat",
        action="store_true",
        help="reproduce the AIST++/Bailando feature bugs, for comparison with published tables",
    )
    p.add_argument("--up", choices=("y", "z"), help="up axis of the motion files (default: what the format says)")
    p.add_argument("--fps", type=bounded_number(float, 0.0, 1000.0, above=True),
                   help="common frame rate, up to 1000 (default: the reference set's)")
    p.add_argument(
        "--suffix",
        dest="suffixes",
        action="append",
        metavar=".EXT",
        help="read only motion files with this suffix (repeatable; default: every registered format's)",
    )
    smpl_model_option(p)
    p.add_argument("--json", action="store_true", help="print the JSON report on stdout (the table goes to stderr)")
    p.set_defaults(run=run)


def check_args(args: argparse.Namespace) -> None:
    """Folders read and files written, checked before any clip is loaded."""
    from pathlib import Path

    from dance_core.checks import check_input_dir, check_output_dir, check_output_file
    from dance_core.cli.checks import check_smpl_model

    generated = check_input_dir(args.generated, "--generated", "folder of motion files")
    reference = check_input_dir(args.reference, "--reference", "folder of motion files")
    wanted = {s.lower() if s.startswith(".") else f".{s.lower()}" for s in args.suffixes or ()}
    check_smpl_model(p for folder in (generated, reference) for p in sorted(folder.iterdir())
                     if p.is_file() and (not wanted or p.suffix.lower() in wanted))
    if args.music is not None:
        check_input_dir(args.music, "--music", "folder of songs")
    out = check_output_file(args.out, "-o")
    if not args.no_plots:
        plots = Path(args.plots) if args.plots else out.with_name(f"{out.stem}-plots")
        check_output_dir(plots, "--plots" if args.plots else "-o (its plot folder)")


def run(args: argparse.Namespace) -> int:
    """Load both sets, attach music beats, run the metrics, print the table, write report and plots."""
    from pathlib import Path

    from rich.console import Console

    from dance_core.evaluation import loading
    from dance_core.evaluation import report as R
    from dance_core.progress import progress_bar
    from dance_core.registry import get_registry

    registry = get_registry()
    for name in args.metrics or []:
        registry.get("metric", name)
    check_args(args)
    with progress_bar(args.quiet) as bar:

        def reader(label: str):
            task = bar.add_task(label, total=None, info="") if bar else None
            return (lambda path: bar.update(task, advance=1, info=path.name)) if bar else None

        reference = loading.load_clips(args.reference, registry, args.up, reader("reference"), args.suffixes)
        generated = loading.load_clips(args.generated, registry, args.up, reader("generated"), args.suffixes)
        fps = args.fps or loading.common_fps(reference)[0].fps
        reference, generated = loading.common_fps(reference, fps), loading.common_fps(generated, fps)
        notes = loading.attach_music(generated, args.music, registry, args.tracker) if args.music else []
        names = args.metrics or registry.names("metric")
        task = bar.add_task("metrics", total=len(names), info="") if bar else None
        report = R.evaluate(
            generated,
            reference,
            names,
            compat=args.compat,
            registry=registry,
            progress=(lambda n: bar.update(task, advance=1, info=n)) if bar else None,
        )
    report.notes[:0] = notes
    report.info = {
        "generated": str(args.generated),
        "reference": str(args.reference),
        "music": args.music,
        "tracker": args.tracker if args.music else None,
        "fps": fps,
        "compat": args.compat,
        "clips": {"generated": len(generated), "reference": len(reference)},
    }
    out = Path(args.out)
    if not args.no_plots:
        from dance_core.evaluation.plots import write_plots

        folder = Path(args.plots) if args.plots else out.with_name(f"{out.stem}-plots")
        report.info["plots"] = [str(p) for p in write_plots(generated, folder, args.plot_clips)]
    R.write_json(report, out)
    if args.json:  # the report for scripts on stdout, the table for people on stderr
        import sys

        sys.stdout.write(out.read_text(encoding="utf-8"))
    console = Console(stderr=args.json)
    if not args.quiet:  # -q: nothing (the exit code; --json: the report)
        console.print(R.render_table(report, f"dance evaluate: {len(generated)} generated vs {len(reference)} "
                                             "reference"))
        for name, reason in report.skipped.items():
            console.print(f"[yellow]{name}: n/a:[/] {reason}")
        for note in report.notes:
            console.print(f"[dim]note: {note}[/]")
        plots = report.info.get("plots") or []
        where = f" and {len(plots)} plot(s) in {Path(plots[0]).parent}" if plots else ""
        console.print(f"report: {out}{where}", highlight=False)
    R.check_selected(report, args.metrics)
    R.check_scored(report)  # nothing scored (e.g. every clip NaN): one line, exit 1
    return 0
