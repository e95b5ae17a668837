"""``dance synth``: a click-track test song, or a synthetic dance dataset (songs with a beat-locked dancer).

Registered through the synth default plugin's ``register_commands`` hook (``dance_core.defaults.synth``);
everything heavy is imported when the command runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from dance_core.checks import bounded_number
from dance_core.progress import say


def add_parser(subparsers) -> None:
    """Add the ``synth`` subcommand."""
    p = subparsers.add_parser(
        "synth",
        help="write a click-track test song (FILE.wav), or a synthetic dance dataset (--out DIR)",
        description="Two forms, one at a time:\n"
        "  dance synth FILE.wav [--bpm --seconds --rate --seed]   a click-track test song\n"
        "  dance synth --out DIR [--songs | --music SONG...]      a dataset: songs with a beat-locked dancer",
        epilog="examples:\n"
        "  dance synth song.wav --bpm 128 --seconds 30\n"
        "  dance synth --out data/synth --songs 100 --seconds 60 --jobs 2\n"
        "  dance synth --music my-songs/ --out data/mine --dances 3",
    )
    p.add_argument("out", nargs="?", metavar="FILE.wav", help="click-track WAV file to write")
    p.add_argument("--out", dest="out_dir", metavar="DIR",
                   help="write a dataset instead: songs with a beat-locked dancer (WAV, BVH, beats, labels)")
    p.add_argument("--songs", type=bounded_number(int, 1, 100_000), default=10, help="dataset songs, 1-100000")
    p.add_argument("--music", nargs="+", metavar="SONG",
                   help="with --out: choreograph the dancer to these songs (files or folders) instead")
    p.add_argument("--dances", type=bounded_number(int, 1, 1000), default=1, metavar="N",
                   help="dances per song, 1-1000 (with --out: one dancer each, see --dancers)")
    p.add_argument("--dancers", nargs="+", metavar="NAME",
                   help="with --out: the dancers (classic, bouncer, glider, hitter, popper, wanderer, or all; "
                   "default classic, the dances of before), a different one per dance of a song")
    p.add_argument("--homogeneous", action="store_true",
                   help="with --out: the control set: every dance by the first dancer, one style, one fixed routine")
    p.add_argument("--tracker", choices=["flux", "librosa", "madmom", "auto"], default="flux",
                   help="with --music: beat tracker (madmom's model files are non-commercial)")
    p.add_argument("--fps", type=bounded_number(float, 0.0, 1000.0, above=True), default=60.0,
                   help="dataset motion frame rate, up to 1000")
    p.add_argument("--mocap", metavar="DIR",
                   help="with --out: chain the dances from real moves, the motion-capture takes in DIR (any rig; "
                   "a motion graph cut at the dancers' accents, warped onto the beats) instead of the procedural "
                   "dancer; no move labels")
    p.add_argument("--mocap-exclude", nargs="+", default=[], metavar="PATTERN",
                   help="file name patterns of takes in --mocap to leave out (e.g. held-out takes)")
    p.add_argument("--jobs", type=bounded_number(int, 1, 256), default=1, help="dataset worker processes, 1-256")
    p.add_argument("--bpm", type=bounded_number(float, 20.0, 400.0), default=120.0,
                   help="click-track tempo in beats per minute, 20-400")
    p.add_argument("--seconds", type=bounded_number(float, 0.0, 3600.0, above=True, unit="s"),
                   help="length in seconds, up to 3600 (default: 20 for a click track, 60 for dataset songs)")
    p.add_argument("--rate", type=bounded_number(int, 8000, 192_000, unit="Hz"), default=22050,
                   help="sample rate in Hz, 8000-192000")
    p.add_argument("--seed", type=int, default=0, help="seed of the drone notes and noise")
    p.set_defaults(run=run)


#: bytes of memory a dataset song takes to synthesize, per sample: its five instrument buses (float64) and a
#: little more, mixed down in place (measured: 0.54 GB above the interpreter's for 60 s at 192 kHz, 55 bytes a
#: sample for 30 s at 22050 Hz; 110 before the in-place mix-down)
SONG_BYTES = 60


def run(args: argparse.Namespace) -> int:
    """A click track with beats every 60/bpm seconds (downbeat every 4th), or a dataset (``--out DIR``)."""
    from dance_core.checks import check_output_dir, check_output_file, refuse_beyond_memory, refuse_same_names
    from dance_core.errors import DanceError

    if args.out is not None and args.out_dir is not None:
        raise DanceError(
            f"synth: give either FILE.wav ({args.out}: a click track) or --out DIR ({args.out_dir}: a dataset), "
            "not both"
        )
    if args.music and args.out_dir is None:
        raise DanceError("synth: --music needs --out DIR (the folder to write the dances into)")
    if args.mocap is not None and (args.out_dir is None or not Path(args.mocap).is_dir()):
        raise DanceError(f"--mocap {args.mocap}: needs --out DIR and a folder of motion files")
    if args.out_dir is not None:
        if args.music:
            for song in args.music:
                if not Path(song).exists():
                    raise DanceError(f"--music {song}: no such file or folder")
            from dance_core.registry import get_registry
            from dance_core.synth.synthetic_dance import music_files

            refuse_same_names(music_files(args.music, get_registry()), "--music")  # a/x.wav, b/x.wav: one x.bvh
        elif args.seconds is not None and args.seconds < 2.0:
            raise DanceError(f"--seconds {args.seconds:g}: a dataset song needs at least 2 s")
        else:  # each worker synthesizes a whole song: about SONG_BYTES a sample
            seconds = 60.0 if args.seconds is None else args.seconds
            refuse_beyond_memory(SONG_BYTES * seconds * args.rate * min(args.jobs, args.songs),
                                 f"synth --seconds {seconds:g} --rate {args.rate} --jobs {args.jobs}",
                                 "--seconds, --rate or --jobs")
        check_output_dir(args.out_dir, "--out")
        return write_dances(args)
    if args.out is None:
        raise DanceError("synth: give a WAV file to write, or --out DIR for a synthetic dance dataset")
    seconds = 20.0 if args.seconds is None else args.seconds
    if seconds < 0.5:
        raise DanceError(f"--seconds {seconds:g}: a click track needs at least 0.5 s (the shortest song dance reads)")
    if Path(args.out).suffix.lower() not in (".wav", ".wave") and not Path(args.out).is_dir():
        raise DanceError(f"{args.out}: a click track is a .wav file; for a dataset folder use --out DIR")
    check_output_file(args.out, None, suffixes=(".wav", ".wave"))

    import numpy as np

    from dance_core.data.synthetic_beats import click_chunks
    from dance_core.formats.wav import write_wav_chunks

    beats = np.arange(0.0, seconds, 60.0 / args.bpm)  # written piece by piece: an hour at 192 kHz stays small
    write_wav_chunks(args.out, click_chunks(beats, seconds, args.rate, np.random.default_rng(args.seed)), args.rate)
    say(args, args.out)
    return 0


def write_dances(args: Any) -> int:
    """``dance synth --out DIR --songs N --seed S [--dances K --dancers NAME... --homogeneous]`` (or
    ``--music SONGS``): write a dataset, say where. ``--dancers all`` names every dancer."""
    from dance_core.errors import DanceError
    from dance_core.synth.dancer import CLASSIC, dancer_names
    from dance_core.synth.synthetic_dance import write_dataset, write_music_dances

    dancers = args.dancers or [CLASSIC]
    homogeneous = bool(args.homogeneous)
    if args.music:
        if dancers != [CLASSIC] or homogeneous:
            raise DanceError("synth: --dancers and --homogeneous are for synthetic songs (--songs), not --music")
        if not (1 <= args.dances <= 1000) or args.fps <= 0:
            raise DanceError("synth: need 1 <= --dances <= 1000 and --fps > 0")
        names = write_music_dances(args.out_dir, args.music, args.dances, args.seed, args.fps, args.tracker,
                                   args.mocap, tuple(args.mocap_exclude))
        say(args, _dataset_line(args.out_dir, names, f"{len(names)} dance(s)", "song"))
        return 0
    seconds = 60.0 if args.seconds is None else args.seconds
    if not (1 <= args.songs <= 100_000) or not (2.0 <= seconds <= 3600) or args.fps <= 0 or args.rate < 8000:
        raise DanceError("synth: need 1 <= --songs, 2 <= --seconds <= 3600, --fps > 0, --rate >= 8000")
    try:
        chosen = None if "all" in dancers else dancer_names(dancers)
    except ValueError as exc:
        raise DanceError(f"synth: --dancers: {exc}") from exc
    names = write_dataset(args.out_dir, args.songs, args.seed, seconds, args.fps, rate=args.rate,
                          dances_per_song=args.dances, jobs=max(1, args.jobs), dancers=chosen, homogeneous=homogeneous,
                          mocap=args.mocap, mocap_exclude=tuple(args.mocap_exclude))
    what = f"{args.songs} song(s) x {args.dances} dances" if args.dances > 1 else f"{len(names)} song(s)"
    say(args, _dataset_line(args.out_dir, names, what, ".wav"))
    return 0


def _dataset_line(out: str, names: list[str], what: str, song: str) -> str:
    """What ``dance synth --out`` wrote: every file counted (``write_clip`` writes the song and one file per
    suffix of ``CLIP_SUFFIXES`` for each clip), the clips' first and last names and the kinds of files."""
    from dance_core.synth.synthetic_dance import CLIP_SUFFIXES

    files = len(names) * (1 + len(CLIP_SUFFIXES))
    return f"{out}: {files} files, {what} ({names[0]} ... {names[-1]}), each {song} {' '.join(CLIP_SUFFIXES)}"
