"""``dance live``: a recipe's model dancing to music as it plays (registered through core's hooks)."""

from __future__ import annotations

import argparse
import json
import sys

from dance_core.checks import bounded_number


def add_parser(subparsers) -> None:
    """Add the ``live`` subcommand."""
    p = subparsers.add_parser(
        "live",
        help="dance to music as it plays: audio in, poses out as they are generated",
        description="Dance to music as it arrives: a file played at real time, raw PCM on standard input or a "
        "microphone in; poses out as JSON Lines, to a WebSocket (with a live page) or as VMC over OSC. Features, "
        "beats and generation are causal; the model waits for its look-ahead of music (see docs/live.md).",
        epilog="examples:\n"
        "  dance live default --input song.ogg --output -\n"
        "  ffmpeg -i song.mp3 -f s16le -ac 1 -ar 22050 - | dance live default --input - --rate 22050 --output -\n"
        "  dance live default --input song.ogg --output ws://127.0.0.1:8765 --open\n"
        "  dance live default --input mic --output osc://127.0.0.1:39539 --json\n"
        '  dance live tm2d-small --input song.ogg --output - --text "10-20: a person jumps" --control -',
    )
    p.add_argument("recipe", help="recipe file or bundled recipe name (dance recipe list)")
    p.add_argument("--input", required=True, metavar="SOURCE",
                   help="a music file (played at real time), - (raw s16le mono PCM on standard input) or mic")
    p.add_argument("--output", action="append", required=True, metavar="SINK",
                   help="- (JSON Lines on standard output), ws://HOST:PORT or osc://HOST:PORT (repeatable)")
    p.add_argument("--rate", type=bounded_number(int, 8000, 192000, unit="Hz"), metavar="HZ",
                   help="sample rate of --input - and mic, 8000-192000 (default: 22050)")
    p.add_argument("--speed", type=bounded_number(float, 0.0, 100.0, above=True), default=1.0,
                   help="play a file this many times faster than real time (tests, benchmarks)")
    p.add_argument("--checkpoint", help="model checkpoint (default: compose.checkpoint)")
    p.add_argument("--seed-motion", metavar="FILE", help="motion file to start from, or 'rest'")
    p.add_argument("--max-lag", type=bounded_number(float, 0.0, 60.0, above=True), default=0.25, metavar="S",
                   help="seconds generation may fall behind before it drops frames")
    p.add_argument("--idle", type=bounded_number(float, 0.0, 3600.0, above=True), default=10.0, metavar="S",
                   help="end with an error when standard input sends nothing for S seconds")
    p.add_argument("--text", dest="texts", action="append", default=[], metavar="START-END: TEXT",
                   help='a text span in seconds of music, e.g. "10-20: a person jumps", or "now: TEXT" (from the '
                        "start, 4 s); repeatable; models that read text only (tm2d-small)")
    p.add_argument("--control", metavar="SOURCE",
                   help="text commands while dancing, one a line (now: TEXT, START-END: TEXT): - (standard input, "
                        "unless it carries the audio) or tcp://127.0.0.1:PORT (answers ok/error per line)")
    p.add_argument("--lookahead", type=bounded_number(float, 0.0, 60.0), metavar="S",
                   help="seconds of music a song-level model (tm2d-small) waits for past a token (default: the "
                        "model's own, 0 for tm2d-small; its whole reach, 6.4 s, gives compose's tokens for the same "
                        "features)")
    p.add_argument("--silence", type=_silence_level, default=-70.0, metavar="DBFS",
                   help="audio below this level, or 40 dB below the loudest second heard, for half a second is "
                        "silence: the figure comes to rest, standing, and dances again as the music returns; off: "
                        "it dances on (default: -70)")
    p.add_argument("--open", action="store_true", help="open the live page of the ws:// output in a browser")
    p.add_argument("--json", action="store_true",
                   help="print a JSON summary at the end: latency distribution, drops (on stderr when --output -)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="FIELD=VALUE",
                   help="override a recipe field, e.g. --set compose.temperature=0.5 (repeatable)")
    p.set_defaults(run=run)


def _silence_level(text: str) -> float | None:
    """``--silence``: a level in dBFS from -120 to 0, or ``off`` (None)."""
    return None if text == "off" else bounded_number(float, -120.0, 0.0, unit="dBFS")(text)


def run(args: argparse.Namespace) -> int:
    """Open the outputs (ports, hosts) and the input, load the model, dance until the input ends."""
    from dance_core.api import Composer
    from dance_core.compose.inputs import reads_text
    from dance_core.errors import DataError
    from dance_core.live.control import open_control
    from dance_core.live.session import LiveSession
    from dance_core.live.sinks import open_sinks
    from dance_core.live.sources import PcmSource, open_source
    from dance_core.live.texts import parse_command
    from dance_core.recipe import load_recipe
    from dance_core.registry import get_registry

    recipe = load_recipe(args.recipe, args.sets)
    if (args.texts or args.control) and not reads_text(recipe, get_registry()):
        raise DataError(f"--text/--control: recipe {recipe.name} reads no text (no text stream in its features); "
                        "a model that does, such as tm2d-small, can follow text live")
    for given in args.texts:
        parse_command(given, 0.0)  # a malformed span is one line before anything opens
    sinks = open_sinks(args.output, f"dance live: {recipe.name}")
    control = None
    try:
        control = open_control(args.control, args.input == "-")
        source = open_source(args.input, args.rate, args.speed, None, recipe.format_options) \
            if args.input in ("-", "mic") else _file_source(args, recipe)
        if isinstance(source, PcmSource):
            source.idle = args.idle
        session = LiveSession(Composer(recipe, args.checkpoint), source, sinks, args.seed_motion, args.max_lag,
                              args.texts, control, args.lookahead, args.silence)
    except BaseException:
        for sink in sinks:
            sink.shutdown()
        if control is not None:
            control.shutdown()
        raise
    if args.open:
        _open_page(sinks, args.quiet)
    summary = session.run()
    if args.json:
        out = sys.stderr if "-" in args.output else sys.stdout
        print(json.dumps(summary, indent=2), file=out)
    elif not args.quiet:
        lat = summary["latency_ms"]
        print(f"live: {summary['frames']} frames over {summary['music_seconds']:.1f} s of music, "
              f"{summary['dropped_frames']} dropped, latency p50 {lat.get('p50', 0):.0f} ms "
              f"p95 {lat.get('p95', 0):.0f} ms ({summary['stopped']})", file=sys.stderr)
    return 0


def _file_source(args: argparse.Namespace, recipe):
    from dance_core.checks import check_input_file
    from dance_core.live.sources import FileSource
    from dance_core.registry import get_registry

    check_input_file(args.input, "--input", "music file")
    return FileSource(args.input, get_registry(), recipe.format_options, args.speed)


def _open_page(sinks, quiet: bool) -> None:
    import webbrowser

    from dance_core.live.websocket import WebSocketSink

    pages = [s.url for s in sinks if isinstance(s, WebSocketSink)]
    if not pages:
        print("dance: warning: live: --open needs a ws:// output; no page to open", file=sys.stderr)
        return
    webbrowser.open(pages[0])
    if not quiet:
        print(f"live: page at {pages[0]}", file=sys.stderr)
