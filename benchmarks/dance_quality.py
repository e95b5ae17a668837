"""Dance quality of a model on real songs: beat locking, floor contact, smoothness, drift, speed.

    .venv/bin/python benchmarks/dance_quality.py [RECIPE] [--checkpoint PATH] [--music SONG ...]
        [--samples N] [--tracker auto|madmom|flux|librosa] [--set FIELD=VALUE ...] [--controls] [--readme]
    .venv/bin/python benchmarks/dance_quality.py --motion-dir DIR [--music SONG ...]   # score BVH files
    .venv/bin/python benchmarks/dance_quality.py --reference                           # the synthetic dancer

For every song (default: the fixture songs ``../shared/fixtures/audio/*.ogg`` next to the repository)
it runs ``dance compose RECIPE --music SONG --out TMP --set compose.formats=[bvh]
--set compose.samples=N`` in a fresh process (its wall time gives the real-time factor: song
seconds / wall seconds, start-up and feature extraction included; the same over the process's CPU
time is shown in brackets, less sensitive to other jobs on a shared machine), reads the BVH files back
through core's motion formats and forward kinematics (``dance_core.evaluation.loading``), tracks
the song's beats with dance-audio (``track_beats``) and scores every dance with
``dance_core.evaluation.quality``. With ``--motion-dir`` the dances are read from a folder instead
(``SONG.bvh`` or ``SONG-k.bvh`` for song stem ``SONG``) and nothing is composed.

Reference dances: the synthetic dancer the bundled model learns from (``synthetic-dance``, seed 0,
songs 0..``--references``-1, 60 s, 80-140 BPM) generated directly at the dances' frame rate; speed
and jerk are reported as ratios to their mean. ``--reference`` scores those dances themselves
against their own known beats (a sanity check of the measures: locking should be high).

Targets (one ✓/✗ column each): **L** body locking (the body's own accents, so a rigid figure bobbing
on the beat has none: :func:`dance_core.evaluation.body_locking`) ≥ 3× the wrong-tempo control (taken
as at least 0.05); the older pelvis-minima locking is shown beside it, not judged (a bounce scores
high on it); **F** both soles more than 5 cm up in ≤ 10 % of frames and no 10-s stretch whose median
lowest sole is above 5 cm (soles where the skeleton shows them, as grounding finds them: a dancer on
the balls of her feet is on the floor); **S** jerk ≤ 1.5× and mean speed 0.5-2× the real dances' (the
held-out CMU takes of ``benchmarks/realism.py`` at the dances' frame rate; the synthetic dancer without
the mocap folder); **D** last-30-s speed 0.5-2× the first 30 s, and no loop: the last 40 s repeat no stretch
0.5-20 s before them closer than 5 cm on average (``loop``, :func:`dance_core.evaluation.repetition.
self_repetition`: poses about the pelvis, facing one way; the held-out real takes 5.9-17.9 cm, a looping
LSTM dancer 0.8-5.5 cm); **R** at least 3× faster than real time.
``--readme`` writes the table into benchmarks/README.md between the ``quality`` markers.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from readme_section import write_section

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_MUSIC = ROOT.parent / "shared" / "fixtures" / "audio"
TIMES = "times.json"  # compose wall and CPU times kept next to the dances (--keep)
REFERENCE = {"seed": 0, "seconds": 60.0, "bpm": (80.0, 140.0), "rate": 22050}

# the targets
MIN_LOCKING_RATIO = 3.0
MAX_FLOAT, MAX_STRETCH = 0.10, 0.05
MAX_JERK, SPEED_RANGE, DRIFT_RANGE = 1.5, (0.5, 2.0), (0.5, 2.0)
MIN_REAL_TIME = 3.0


@dataclass
class Dance:
    """One dance to score: joint positions (m, Y up), frame rate, joint names and parents."""

    positions: np.ndarray
    fps: float
    names: list[str] | None
    parents: list[int] | None
    soles: np.ndarray | None = None  # (T, 2) sole heights (m) where the skeleton shows the soles


@dataclass
class Row:
    """One model x song: the per-dance scores averaged over samples, plus diversity and speed."""

    model: str
    song: str
    scores: dict[str, float]
    samples: int = 1
    diversity: float = float("nan")
    real_time: float = float("nan")
    real_time_cpu: float = float("nan")
    notes: list[str] = field(default_factory=list)


# --- inputs ---------------------------------------------------------------------------------------


def registry():
    """Core's registry with every installed plugin."""
    from dance_core import get_registry

    return get_registry()


def read_dance(path: Path) -> Dance:
    """A motion file as a Y-up dance in metres (the loading helpers of ``dance evaluate``)."""
    from dance_core.api import read_motion
    from dance_core.evaluation import joint_positions, z_up_to_y_up

    data = read_motion(path)
    positions, names, up = joint_positions(data, str(path))
    if up == "z":
        positions = z_up_to_y_up(positions)
    from dance_core.motion import soles

    skeletal = getattr(data, "skeleton_motion", None)
    parents = list(skeletal.skeleton.parents) if skeletal is not None else None
    feet = soles(skeletal) if skeletal is not None and up != "z" else None
    return Dance(positions, float(data.fps), names, parents, feet)


def song_audio(song: Path):
    """The song read by the registered audio readers."""
    from dance_core import load_audio

    return load_audio(song, registry())


def song_beats(audio, tracker: str) -> np.ndarray:
    """Beat times (s) from dance-audio's tracker."""
    from dance_audio.beats import track_beats

    return np.asarray(track_beats(audio, tracker=tracker).times, dtype=np.float64)


def dance_files(folder: Path, stem: str) -> list[Path]:
    """``stem.bvh`` or ``stem-k.bvh`` files in a folder (sorted)."""
    exact = folder / f"{stem}.bvh"
    if exact.is_file():
        return [exact]
    samples = [p for p in folder.glob("*.bvh") if p.stem.rsplit("-", 1)[0] == stem]
    return sorted(p for p in samples if p.stem[len(stem) + 1 :].isdigit())


def compose(recipe: str, song: Path, out: Path, samples: int, checkpoint: str | None, sets: list[str], threads: int):
    """Run ``dance compose`` in a fresh process; return (command, wall seconds, its CPU seconds)."""
    dance = Path(sys.executable).with_name("dance")
    cmd = [
        str(dance),
        "-q",
        "compose",
        recipe,
        "--music",
        str(song),
        "--out",
        str(out),
        "--set",
        "compose.formats=[bvh]",
        "--set",
        f"compose.samples={samples}",
    ]
    if checkpoint:
        cmd += ["--checkpoint", checkpoint]
    for s in sets:
        cmd += ["--set", s]
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        raise RuntimeError(f"{shlex.join(cmd)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return cmd, wall, cpu


def read_times(folder: Path) -> dict[str, list[float]]:
    """Compose [wall, CPU] seconds by song stem that an earlier run kept in ``folder/times.json``."""
    path = folder / TIMES
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}


def write_time(folder: Path, stem: str, wall: float, cpu: float) -> None:
    """Record a song's compose wall and CPU time in ``folder/times.json`` (so ``--motion-dir`` can report it)."""
    times = read_times(folder)
    times[stem] = [wall, cpu]
    (folder / TIMES).write_text(json.dumps(times, indent=1), encoding="utf-8")


def reference_dances(n: int, fps: float) -> list[tuple[str, Dance, np.ndarray]]:
    """The synthetic dancer's first ``n`` dances at ``fps`` with their known beats."""
    from dance_core.synth import make_clip

    out = []
    for i in range(n):
        clip = make_clip(i, fps=fps, **REFERENCE)
        motion = clip.motion.skeleton_motion
        dance = Dance(
            np.asarray(motion.positions(), dtype=np.float64),
            fps,
            list(motion.skeleton.names),
            list(motion.skeleton.parents),
        )
        out.append((clip.name, dance, np.asarray(clip.meta["beats"], dtype=np.float64)))
    return out


# --- scores ---------------------------------------------------------------------------------------


def score_dances(model: str, song: str, dances: list[Dance], beats: np.ndarray) -> Row:
    """Every quality measure of the dances of one song (means over the samples) and their diversity."""
    from dance_core.evaluation import body_locking, quality_scores, sample_diversity

    per = []
    for d in dances:
        scores = quality_scores(d.positions, d.fps, beats, d.names, d.parents, d.soles)
        body = body_locking(d.positions, d.fps, d.names, beats[beats < len(d.positions) / d.fps])
        scores.update(body_locking=body["locking"], body_control=body["control"])
        per.append(scores)
    keys = per[0].keys()
    mean = {
        k: float(np.nanmean([p[k] for p in per])) if any(np.isfinite(p[k]) for p in per) else float("nan") for k in keys
    }
    div = sample_diversity([d.positions for d in dances]) if len(dances) > 1 else float("nan")
    return Row(model, song, mean, len(dances), div)


def real_dances(mocap: Path, fps: float) -> list[Dance]:
    """The held-out real takes (``benchmarks/realism.py``'s ``HELD_OUT``) on dance24 at ``fps``, or none
    when the folder is missing."""
    from realism import HELD_OUT

    from dance_core import DatasetContext, get_registry
    from dance_core.motion import soles

    if not mocap.is_dir():
        return []
    dataset = get_registry().create("dataset", "mocap", {"path": str(mocap)}, DatasetContext(fps=fps))
    out = []
    for clip in dataset.clips():
        if clip.name in HELD_OUT:
            m = clip.motion.skeleton_motion
            out.append(Dance(m.positions(), fps, list(m.skeleton.names), list(m.skeleton.parents), soles(m)))
    return out


def reference_means(refs: list[tuple[str, Dance, np.ndarray]], fps: float, real: list[Dance]) -> dict[str, float]:
    """Mean speed and jerk of the real held-out dances (else of the synthetic reference dances), and the
    diversity of three synthetic dances of one song."""
    from dance_core.evaluation import sample_diversity, smoothness
    from dance_core.synth import make_clip

    values = [smoothness(d.positions, d.fps) for d in real] or [smoothness(d.positions, d.fps) for _, d, _ in refs]
    out = {k: float(np.mean([v[k] for v in values])) for k in ("speed", "jerk")}
    out["real"] = float(len(real))
    same_song = [
        make_clip(k, fps=fps, dances_per_song=3, **REFERENCE).motion.skeleton_motion.positions() for k in range(3)
    ]
    out["diversity"] = sample_diversity(same_song)
    return out


def targets(row: Row, ref: dict[str, float]) -> dict[str, bool | None]:
    """Which of the five targets a row meets (None where it cannot be judged)."""
    from dance_core.evaluation import LOOP_BELOW

    s = row.scores
    speed, jerk = s["speed"] / ref["speed"], s["jerk"] / ref["jerk"]

    def judged(ok, *values):
        return None if not all(np.isfinite(v) for v in values) else bool(ok)

    control = max(s["body_control"], 0.05) if np.isfinite(s["body_control"]) else 0.05
    return {  # a dance with no accents of its own (a still or rigid figure) fails L
        "L": bool(np.isfinite(s["body_locking"]) and s["body_locking"] >= MIN_LOCKING_RATIO * control),
        "F": judged(s["float"] <= MAX_FLOAT and s["worst_stretch"] <= MAX_STRETCH, s["float"], s["worst_stretch"]),
        "S": judged(jerk <= MAX_JERK and SPEED_RANGE[0] <= speed <= SPEED_RANGE[1], speed, jerk),
        "D": judged(DRIFT_RANGE[0] <= s["drift"] <= DRIFT_RANGE[1] and not s["repeat"] < LOOP_BELOW, s["drift"]),
        "R": judged(row.real_time >= MIN_REAL_TIME, row.real_time),
    }


def fmt(value: float, digits: int = 2) -> str:
    """A number for the table, or an em dash."""
    return "—" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def mark(ok: bool | None) -> str:
    """✓, ✗ or an em dash."""
    return "—" if ok is None else ("✓" if ok else "✗")


HEADER = [
    "model",
    "song",
    "s",
    "body locking",
    "control",
    "pelvis locking (speed / hips), control",
    "float %",
    "below %",
    "worst 10-s median foot (cm)",
    "skating (m/s)",
    "speed ×ref",
    "jerk ×ref",
    "drift (last/first 30 s)",
    "loop (cm)",
    "foot trend (cm/min)",
    "bone",
    "diversity (m)",
    "× real time, wall (CPU)",
    "L",
    "F",
    "S",
    "D",
    "R",
]


def table(rows: list[Row], ref: dict[str, float]) -> list[str]:
    """The markdown table: one line per model x song."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    for r in rows:
        s, t = r.scores, targets(r, ref)
        cells = [
            r.model,
            r.song,
            f"{s['seconds']:.0f}",
            f"**{fmt(s['body_locking'])}**",
            fmt(s["body_control"]),
            f"{fmt(s['locking'])} ({fmt(s['locking_speed'])} / {fmt(s['locking_hips'])}), {fmt(s['control'])}",
            fmt(100 * s["float"], 0),
            fmt(100 * s["below_floor"], 0),
            fmt(100 * s["worst_stretch"], 1),
            fmt(s["skating"]),
            fmt(s["speed"] / ref["speed"]),
            fmt(s["jerk"] / ref["jerk"]),
            fmt(s["drift"]),
            fmt(100 * s["repeat"], 1),
            fmt(100 * s["foot_trend"], 1),
            fmt(s["bone"], 3),
            fmt(r.diversity),
            f"{fmt(r.real_time, 1)} ({fmt(r.real_time_cpu, 1)})",
            *(mark(t[k]) for k in "LFSDR"),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def summary(rows: list[Row], ref: dict[str, float]) -> str:
    """One line: how many rows meet each target."""
    parts = []
    for key in "LFSDR":
        judged = [targets(r, ref)[key] for r in rows]
        judged = [j for j in judged if j is not None]
        parts.append(f"{key} {sum(judged)}/{len(judged)}" if judged else f"{key} —")
    return "Targets met (rows): " + ", ".join(parts) + "."


def machine(threads: int) -> str:
    """The machine in words."""
    load = f", load average {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    try:
        import torch

        version = f", torch {torch.__version__}"
    except ImportError:
        version = ""
    return f"{platform.machine()}, {os.cpu_count()} cores{load}, {threads} torch thread(s){version}"


def main(argv: list[str] | None = None) -> None:
    """Compose (or read) the dances, score them, print the table, optionally write the README."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("recipe", nargs="?", default="default", help="recipe to compose with (default: default)")
    parser.add_argument("--checkpoint", help="model checkpoint (default: the recipe's)")
    parser.add_argument("--music", nargs="+", type=Path, help=f"songs (default: {DEFAULT_MUSIC}/*.ogg)")
    parser.add_argument("--samples", type=int, default=1, help="dances per song (default 1)")
    parser.add_argument("--tracker", default="flux",
                        help="dance-audio beat tracker: flux (default, the beats extractor's), librosa, madmom or "
                             "auto (madmom's weights are non-commercial: opt-in)")
    parser.add_argument(
        "--set",
        dest="sets",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="recipe override passed to dance compose (repeatable)",
    )
    parser.add_argument("--threads", type=int, default=1, help="OMP threads of the compose process (default 1)")
    parser.add_argument("--motion-dir", type=Path, help="score the BVH files of this folder instead of composing")
    parser.add_argument(
        "--keep",
        type=Path,
        help="compose into this folder (kept, with the compose times in "
        "times.json, for a later --motion-dir) instead of a temporary one",
    )
    parser.add_argument("--reference", action="store_true", help="score the synthetic reference dances themselves")
    parser.add_argument("--mocap", type=Path, default=ROOT.parent / "shared" / "mocap" / "cmu-dance",
                        help="real dance takes whose held-out ones are the speed and jerk reference")
    parser.add_argument("--references", type=int, default=4, help="synthetic reference dances (default 4)")
    parser.add_argument("--controls", action="store_true",
                        help="also score, per song, a rigid T-pose bobbing 4 cm on its beats (must fail L)")
    parser.add_argument("--name", help="model name in the table (default: the recipe, or the folder)")
    parser.add_argument("--date", default=datetime.date.today().isoformat(), help="date for --readme")
    parser.add_argument("--readme", action="store_true", help="write the table into benchmarks/README.md")
    args = parser.parse_args(argv)

    rows: list[Row] = []
    fps = None
    if args.reference:
        refs = reference_dances(args.references, 20.0)
        for name, dance, beats in refs:
            rows.append(score_dances("synthetic dancer (known beats)", name, [dance], beats))
    else:
        songs = args.music or sorted(DEFAULT_MUSIC.glob("*.ogg"))
        if not songs:
            raise SystemExit(f"no songs (looked in {DEFAULT_MUSIC})")
        model = args.name or (args.motion_dir.name if args.motion_dir else args.recipe)
        if args.checkpoint and not args.name:
            model += f" ({Path(args.checkpoint).name})"
        with tempfile.TemporaryDirectory(prefix="dance-quality-") as tmp:
            for song in songs:
                audio = song_audio(song)
                seconds = len(audio.samples) / audio.rate
                beats = song_beats(audio, args.tracker)
                if args.motion_dir:
                    folder = args.motion_dir
                    wall, cpu = read_times(folder).get(song.stem, [float("nan")] * 2)
                else:
                    folder = args.keep or Path(tmp)
                    print(f"composing {song.name} ({seconds:.0f} s) ...", file=sys.stderr, flush=True)
                    _, wall, cpu = compose(
                        args.recipe, song, folder, args.samples, args.checkpoint, args.sets, args.threads
                    )
                    write_time(folder, song.stem, wall, cpu)
                files = dance_files(folder, song.stem)
                if not files:
                    print(f"{song.stem}: no {song.stem}.bvh or {song.stem}-k.bvh in {folder}", file=sys.stderr)
                    continue
                dances = [read_dance(f) for f in files]
                row = score_dances(model, song.stem, dances, beats)
                row.real_time = seconds / wall if np.isfinite(wall) else float("nan")
                row.real_time_cpu = seconds / cpu if np.isfinite(cpu) and cpu > 0 else float("nan")
                rows.append(row)
                print(
                    f"{song.stem}: {len(beats)} beats, body locking {row.scores['body_locking']:.2f}, float "
                    f"{100 * row.scores['float']:.0f} %, {row.real_time:.1f}x real time",
                    file=sys.stderr,
                )
                fps = dances[0].fps
                if args.controls:
                    from realism import statue

                    from dance_core.motion import soles

                    still = statue(beats, seconds, fps)
                    figure = Dance(still.positions(), fps, list(still.skeleton.names), list(still.skeleton.parents),
                                   soles(still))
                    rows.append(score_dances("control: rigid T-pose bobbing on the beat", song.stem, [figure],
                                             beats))
    if not rows:
        raise SystemExit("nothing scored")
    fps = fps or 20.0
    ref = reference_means(reference_dances(args.references, fps), fps, real_dances(args.mocap, fps))
    command = "benchmarks/dance_quality.py " + shlex.join(
        a for a in (argv if argv is not None else sys.argv[1:]) if a != "--readme"
    )
    lines = [
        f"Command: `OMP_NUM_THREADS={args.threads} .venv/bin/python {command.strip()}`; {args.date}; "
        f"{machine(args.threads)}; beats: dance-audio tracker `{args.tracker}`"
        + ("" if not args.reference else " (reference rows: the songs' known beats)")
        + (f"; speed and jerk reference: {ref['real']:.0f} held-out real CMU takes at {fps:g} fps"
           if ref["real"] else f"; speed and jerk reference: synthetic dancer songs 0-{args.references - 1}, 60 s "
           f"at {fps:g} fps (no mocap folder)")
        + f" (mean speed {ref['speed']:.2f} m/s, jerk {ref['jerk']:.0f} m/s³); three synthetic dances of one song: "
        f"diversity {ref['diversity']:.2f} m.",
        "",
        *table(rows, ref),
        "",
        summary(rows, ref),
    ]
    text = "\n".join(lines)
    print(text)
    if args.readme:
        write_section("quality", text)


if __name__ == "__main__":
    main()
