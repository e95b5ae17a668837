"""TM2D's claim as its own experiment: late fusion switches into the text's move and back coherently,
more so than the slerp-editing baseline, and the prompted move is one a person would recognise.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/claims_tm2d.py [--checkpoint PATH] [--music SONG ...]
        [--seconds 30] [--samples 5] [--moves jump spin ...] [--reference real|synthetic] [--json OUT] [--readme]

For every song (default: the four fixture songs, which no model here trained on; their first
``--seconds``) and every move, ``tm2d-small`` (``--checkpoint``: other weights of it) composes from one
seed, ``--samples`` dances each:

- **a2d**: music only (the paper's a2d row);
- **late fusion**: the prompt over the middle third of the song at the recipe's peak weight (0.8);
- **slerp** (the paper's baseline, ``dance_tokens.slerp.slerp_splice``): the a2d dance with a text-only
  clip spliced over the same span, ``--transition`` frames of quaternion slerp on either side (10 frames
  at the paper's 60 fps: 5 at tm2d-small's 30). The clip is the model's text branch alone: the same
  song composed with the prompt over all of it at weight 1 (ramp 1 %), from its second second on.

Every dance is decoded without grounding, spliced where it is the baseline, then grounded (the same for
all three arms); no beat alignment (the songs carry no beats here), so the span's frames are the model's.

**Coherence at the span's edges**: TM2D's MPD (``dance evaluate``'s ``mpd``: 10 futures by motion
matching over the reference dances, 25 past frames at 60 fps) at ft = 10, 20, 30 at the first frame of
the span and at its end, each point its own clip, with the mean joint speed there beside it
(``mpd_speed``: stillness scores low). Reference (``--reference real``, the default): the CMU dance takes
held out of every training recipe (``realism.HELD_OUT``, retargeted onto dance24 at the model's rate), so
the futures MPD predicts are real dancers' continuations of the motion at the edge; scored themselves
leave-one-out every 2 s (the ground-truth row). ``--reference synthetic``: ``--references`` synthetic
dances of 30 s (seed 1), scored at the starts of their labelled moves: the reference of the runs before
the bundled model learned from real moves, kept for comparison.

**The move, as a person would see it**, per second of the span (share of seconds): jump: a run of
airborne frames (``dance_core.evaluation`` detector) in most of whose frames both feet are at least
``JUMP_CLEAR`` (10 cm) above the dance's floor (the lowest foot's 10th percentile); spin: the hips turn
at least 270° within 2.5 s on the spot (the detector's own rule); clap, kick, arm-wave: their detectors.
The highest both-feet clearance in the span and the largest turn within 2.5 s are reported beside.

The rule, stated before the run (``RULE``): with 95 % bootstrap intervals over songs × moves × samples,
paired (the slerp and the fusion dance of one song, move and sample share the a2d dance before the
span), late fusion is **more coherent** when MPD(slerp) − MPD(fusion) lies above 0 at both edges and
every ft, and the fusion dances move at least ``MIN_SPEED_RATIO`` times as fast as the music-only dances at
the same edges (not stiller than the model's own dancing: a lower MPD must not be stillness; the slerp
arm is not the yardstick, its 5-frame transitions are fast by construction); **does not hold** when any
interval lies wholly below 0; inconclusive otherwise. A move is
**performed** when its share inside the span with the text is at least ``MARGIN`` above the a2d share.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from claims_protocol import bootstrap, ci, decide
from readme_section import write_section
from text_spans import DEFAULT_MUSIC, MARGIN, PROMPTS, load, song_streams, with_text

JUMP_CLEAR = 0.10  # m: both feet this far above the floor
SPIN_WINDOW = 2.5  # s
MIN_SPEED_RATIO = 0.8
FUTURES = (10, 20, 30)
EDGES = ("start", "end")
ARMS = ("a2d", "fusion", "slerp")
SHOWN = (("fusion", "late fusion"), ("slerp", "slerp"), ("a2d", "music only"))  # the moves table's columns
RULE = (f"late fusion is more coherent when the 95 % bootstrap interval (paired over songs × moves × samples) of "
        f"MPD(slerp) − MPD(fusion) lies above 0 at both span edges and ft = 10, 20, 30, and the fusion dances' mean "
        f"joint speed at the edges is at least {MIN_SPEED_RATIO:g}× the music-only dances'; does not hold when any "
        f"interval lies wholly below 0; inconclusive otherwise. A move is performed when its share of the span's "
        f"seconds with the text is at least {MARGIN:g} above the music-only share")


def motions(composer, streams, n: int, name: str, spans=None) -> list:
    """``compose.samples`` dances as skeletal ``Motion``s, decoded, not grounded (``spans``: None = music)."""
    from dance_core.api import Song

    song = Song(name, streams, n, spans=spans)
    motion = composer.generate(song, composer.seed("rest"))
    return [data.skeleton_motion for data in composer.dances(song, motion, ground=False)]


def grounded(motion) -> np.ndarray:
    """Joint positions ``(T, J, 3)`` of the motion put on the floor as ``dance compose`` does."""
    from dance_core.motion import ground

    return np.asarray(ground(motion)[0].positions(), np.float64)


def crop(streams: dict, n: int) -> dict:
    """The first ``n`` frames of every stream."""
    return {k: np.asarray(v)[:n] for k, v in streams.items()}


def jump_seconds(p: np.ndarray, fps: float) -> tuple[np.ndarray, float]:
    """Per frame, the frames of jumps that clear ``JUMP_CLEAR`` with both feet in most of their frames; and the
    lowest foot's height above the floor per frame."""
    from dance_core.evaluation import detect

    feet = p[:, [7, 8, 10, 11], 1].min(axis=1)  # SMPL-24 order: ankles and feet
    clear = feet - np.percentile(feet, 10)
    air = detect("jump", p, fps)
    out = np.zeros(len(p), bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], air.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if np.mean(clear[a:b] >= JUMP_CLEAR) > 0.5:
            out[a:b] = True
    return out, clear


def largest_turn(p: np.ndarray, fps: float, a: int, b: int) -> float:
    """The largest turn (degrees) of the hips' facing within ``SPIN_WINDOW`` seconds inside frames ``[a, b)``."""
    across = p[a:b, 1] - p[a:b, 2]
    yaw = np.unwrap(np.arctan2(-across[:, 2], across[:, 0]))
    w = max(1, int(round(SPIN_WINDOW * fps)))
    if len(yaw) <= w:
        return float(np.degrees(np.ptp(yaw))) if len(yaw) else 0.0
    return float(np.degrees(np.abs(yaw[w:] - yaw[:-w]).max()))


def move_stats(move: str, p: np.ndarray, fps: float, start: float, end: float) -> dict:
    """Share of the span's seconds with the move (strict jump), and its size (clearance, turn)."""
    from dance_core.evaluation import detect, move_share

    a, b = int(round(start * fps)), int(round(end * fps))
    if move == "jump":
        hits, clear = jump_seconds(p, fps)
        return {"share": move_share(hits, fps, start, end), "clearance_cm": 100 * float(clear[a:b].max())}
    out = {"share": move_share(detect(move, p, fps), fps, start, end)}
    if move == "spin":
        out["turn_deg"] = largest_turn(p, fps, a, b)
    return out


def references(count: int, seconds: float, fps: float):
    """Synthetic dances (seed 1) as ``JointClip``s with their labelled moves as texts."""
    from dance_core import JointClip
    from dance_core.synth import make_clip

    out = []
    for i in range(count):
        src = make_clip(i, seed=1, seconds=seconds, bpm=(70.0, 180.0), rate=8000, fps=fps)
        sm = src.motion.skeleton_motion
        texts = [(t.start, t.end, t.text) for t in src.texts]
        out.append(JointClip(f"ref-{i}", sm.positions(), fps, list(sm.skeleton.names), meta={"texts": texts}))
    return out


def real_references(fps: float) -> list:
    """The held-out CMU takes (``realism.HELD_OUT``) as ``JointClip``s at ``fps``, without texts (MPD then
    scores them every 2 s)."""
    from realism import HELD_OUT, MOCAP, real_takes

    from dance_core import JointClip

    takes = real_takes(MOCAP)
    missing = [n for n in HELD_OUT if n not in takes]
    if missing:
        sys.exit(f"{MOCAP}: held-out takes missing: {', '.join(missing)}")
    out = []
    for name in HELD_OUT:
        m = takes[name].resample(fps) if abs(takes[name].fps - fps) > 1e-9 else takes[name]
        out.append(JointClip(name, m.positions(), fps, list(m.skeleton.names)))
    return out


def edge_clip(name: str, p: np.ndarray, fps: float, joints: list[str], at: float):
    """A clip whose one evaluation point is ``at`` seconds (MPD scores text starts)."""
    from dance_core import JointClip

    return JointClip(name, p, fps, joints, meta={"texts": [(at, at + 1.0, "edge")]})


def mpd(clips, reference) -> dict:
    """MPD per clip (one point each): ``{name: {mpd_10, mpd_20, mpd_30, mpd_speed}}``, and the summary."""
    from dance_core.api import EvaluateOptions, evaluate

    report = evaluate(clips, reference, EvaluateOptions(metrics=["mpd"]))
    result = report.results["mpd"]
    return {k: dict(v) for k, v in result.per_clip.items()}, dict(result.values)


def run(args) -> dict:
    """Compose every arm, measure the moves, and MPD at the span edges."""
    from dance_tokens.slerp import slerp_splice

    songs = args.music or sorted(DEFAULT_MUSIC.glob("*.ogg"))
    fusion = load("tm2d-small", args.checkpoint, None, args.samples)
    text_only = load("tm2d-small", args.checkpoint, 1.0, args.samples, ["model.head.ramp=0.01"])
    stack, ckpt = fusion.stack, fusion.checkpoint
    fps = stack.fps
    joints = None
    clips, moves = [], {m: {arm: [] for arm in ARMS} for m in args.moves}
    for song in songs:
        streams, n, _ = song_streams(song, stack, ckpt)
        n = min(n, int(round(args.seconds * fps)))
        streams = crop(streams, n)
        seconds = n / fps
        start, end = round(seconds / 3, 2), round(2 * seconds / 3, 2)
        a, b = int(round(start * fps)), int(round(end * fps))
        plain = motions(fusion, streams, n, song.stem)
        joints = list(plain[0].skeleton.names)
        plain_p = [grounded(m) for m in plain]
        for move in args.moves:
            text_streams, spans = with_text(streams, stack, ckpt, n, PROMPTS[move], start, end)
            fused = [grounded(m) for m in motions(fusion, text_streams, n, song.stem, spans)]
            whole_streams, whole_spans = with_text(streams, stack, ckpt, n, PROMPTS[move], 0.0, seconds)
            lead = int(round(fps))
            length = b - a - 2 * args.transition
            texts = [m.crop(lead, lead + length) for m in motions(text_only, whole_streams, n, song.stem, whole_spans)]
            spliced = [grounded(slerp_splice(d, c, a, args.transition)) for d, c in zip(plain, texts, strict=True)]
            for k, arms in enumerate(zip(plain_p, fused, spliced, strict=True)):
                for arm, p in zip(ARMS, arms, strict=True):
                    moves[move][arm].append(move_stats(move, p, fps, start, end))
                    for edge, at in zip(EDGES, (start, end), strict=True):
                        clips.append(edge_clip(f"{song.stem}|{move}|{k}|{arm}|{edge}", p, fps, joints, at))
            print(f"{song.stem} {move}: share inside fusion "
                  f"{np.mean([s['share'] for s in moves[move]['fusion'][-args.samples:]]):.2f}, slerp "
                  f"{np.mean([s['share'] for s in moves[move]['slerp'][-args.samples:]]):.2f}, a2d "
                  f"{np.mean([s['share'] for s in moves[move]['a2d'][-args.samples:]]):.2f}", flush=True)
    reference = real_references(fps) if args.reference == "real" else references(args.references, 30.0, fps)
    per_clip, summary = mpd(clips, reference)
    _, real = mpd(reference, reference)
    return {"per_clip": per_clip, "summary": summary, "real": real, "moves": moves,
            "songs": [s.stem for s in songs], "fps": fps}


def edge_values(per_clip: dict, arm: str, edge: str, key: str) -> dict:
    """``{(song, move, sample): value}`` of one arm at one edge."""
    out = {}
    for name, v in per_clip.items():
        song, move, k, a, e = name.split("|")
        if a == arm and e == edge:
            out[(song, move, k)] = v[key]
    return out


def paired(per_clip: dict, edge: str, key: str):
    """MPD(slerp) − MPD(fusion) per unit, and its bootstrap interval."""
    s, f = edge_values(per_clip, "slerp", edge, key), edge_values(per_clip, "fusion", edge, key)
    diffs = [s[u] - f[u] for u in sorted(s.keys() & f.keys())]
    return bootstrap(lambda d: d, diffs)


def mean_of(per_clip: dict, arm: str, edge: str, key: str) -> float:
    """The mean of one value over an arm's clips at one edge."""
    v = list(edge_values(per_clip, arm, edge, key).values())
    return float(np.mean(v)) if v else float("nan")


def verdict(result: dict) -> tuple[str, dict, list[str], float]:
    """holds / does not hold / inconclusive for the coherence claim, its intervals, the moves performed and the
    fusion dances' speed at the edges over the music-only dances' (the lower of the two edges)."""
    pc = result["per_clip"]
    intervals = {(e, ft): paired(pc, e, f"mpd_{ft}") for e in EDGES for ft in FUTURES}
    readings = [decide(v) for v in intervals.values()]
    speed = min(mean_of(pc, "fusion", e, "mpd_speed") / mean_of(pc, "a2d", e, "mpd_speed") for e in EDGES)
    if "n/a" in readings:
        word = "inconclusive (nothing scored)"
    elif all(r == "above" for r in readings) and speed >= MIN_SPEED_RATIO:
        word = "holds"
    elif any(r == "below" for r in readings):
        word = "does not hold"
    else:
        word = "inconclusive"
    performed = [m for m, arms in result["moves"].items()
                 if np.nanmean([s["share"] for s in arms["fusion"]]) - np.nanmean([s["share"] for s in arms["a2d"]])
                 >= MARGIN]
    return word, intervals, performed, speed


def ms(values) -> str:
    """Mean ± sd."""
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)])
    return "—" if not len(v) else f"{v.mean():.2f} ± {v.std():.2f}"


def report(result: dict, args, wall: float) -> tuple[str, str]:
    """The README section and the verdict line."""
    import torch

    pc = result["per_clip"]
    word, intervals, performed, speed = verdict(result)
    load_avg = f", load average {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    cmd = "OMP_NUM_THREADS=1 .venv/bin/python benchmarks/claims_tm2d.py " + shlex.join(sys.argv[1:])
    lines = [f"Command: `{cmd}`; {args.date}; {platform.machine()}, {os.cpu_count()} cores{load_avg}, 1 torch thread, "
             f"torch {torch.__version__}; {wall / 60:.1f} min. Model: `tm2d-small` ({args.checkpoint or 'bundled'}); "
             f"songs: {', '.join(result['songs'])} (first {args.seconds:g} s); {args.samples} samples per song and "
             f"move; span = the middle third; slerp transition {args.transition} frames at {result['fps']:g} fps; "
             f"MPD reference: {reference_words(args)}.", "",
             "MPD (m) at the span edges, mean over songs × moves × samples, with the mean joint speed (m/s) of the "
             "scored frames:", "",
             "| arm | edge | MPD ft=10 | ft=20 | ft=30 | speed (m/s) |", "|---|---|---|---|---|---|"]
    real = result["real"]
    where = "every 2 s" if args.reference == "real" else "at their move starts"
    lines.append(f"| real (reference dances {where}, leave-one-out) | — | {real['mpd_10']:.4f} | "
                 f"{real['mpd_20']:.4f} | {real['mpd_30']:.4f} | {real['mpd_speed']:.3f} |")
    for arm in ARMS:
        for e in EDGES:
            cells = " | ".join(f"{mean_of(pc, arm, e, f'mpd_{ft}'):.4f}" for ft in FUTURES)
            lines.append(f"| {arm} | {e} | {cells} | {mean_of(pc, arm, e, 'mpd_speed'):.3f} |")
    lines += ["", "MPD(slerp) − MPD(fusion), paired, 95 % bootstrap interval (positive: late fusion more coherent): "
              + "; ".join(f"{e} ft={ft} {ci(v, 2)}" for (e, ft), v in intervals.items()), "",
              "The prompted move inside the span (share of seconds; jump: both feet ≥ 10 cm up in most of a jump's "
              "frames; spin: ≥ 270° within 2.5 s on the spot), mean ± sd over songs × samples:", "",
              "| move | " + " | ".join(label for _, label in SHOWN) + " | size in the span ("
              + " / ".join(label for _, label in SHOWN) + ") |",
              "|---|---|---|---|---|"]
    for m, arms in result["moves"].items():
        size_key = {"jump": "clearance_cm", "spin": "turn_deg"}.get(m)
        size = " / ".join(ms([s[size_key] for s in arms[a]]) for a, _ in SHOWN) if size_key else "—"
        unit = {"jump": " cm highest both-feet clearance", "spin": "° largest turn in 2.5 s"}.get(m, "")
        shares = " | ".join(ms([s["share"] for s in arms[a]]) for a, _ in SHOWN)
        lines.append(f"| {m} | {shares} | {size}{unit} |")
    failed = [m for m in result["moves"] if m not in performed]
    lines += ["", f"Moves performed with late fusion (share ≥ {MARGIN:g} above music only): "
              f"{', '.join(performed) or 'none'}; not performed: {', '.join(failed) or 'none'}."]
    fus = [mean_of(pc, "fusion", e, "mpd_20") for e in EDGES]
    slp = [mean_of(pc, "slerp", e, "mpd_20") for e in EDGES]
    line = (f"- **TM2D** (late fusion switches into the text's move and back more coherently than the slerp editing "
            f"baseline, MPD at the span edges; the move is one a person would recognise): MPD_20 start / end "
            f"fusion {fus[0]:.3f} / {fus[1]:.3f} vs slerp {slp[0]:.3f} / {slp[1]:.3f} m (real "
            f"{real['mpd_20']:.3f}); slerp − fusion "
            + "; ".join(f"{e} ft={ft} {ci(v, 2)}" for (e, ft), v in intervals.items())
            + f"; fusion speed at the edges {speed:.2f}× the music-only dances'"
            + f"; moves performed {len(performed)}/{len(result['moves'])} ({', '.join(performed) or 'none'}; "
            f"failing: {', '.join(failed) or 'none'}); {len(result['songs'])} songs × {args.samples} samples, "
            f"tm2d-small {'bundled' if not args.checkpoint else args.checkpoint}: **{word}**. Rule: {RULE}. "
            f"(benchmarks/claims_tm2d.py; its section \"TM2D: late fusion against slerp at the span edges\")")
    return "\n".join(lines) + "\n\n" + line + "\n", line


def reference_words(args) -> str:
    """What MPD's reference was, for the report."""
    if args.reference == "real":
        from realism import HELD_OUT

        return f"the {len(HELD_OUT)} CMU dance takes held out of training ({', '.join(HELD_OUT)})"
    return f"{args.references} synthetic dances of 30 s (seed 1)"


def main(argv: list[str] | None = None) -> int:
    """Run the experiment, print the section, optionally write it into benchmarks/README.md."""
    import torch

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--checkpoint", help="tm2d-small weights (default: the bundled ones)")
    p.add_argument("--music", nargs="+", type=Path)
    p.add_argument("--seconds", type=float, default=30.0, help="first seconds of each song (default 30)")
    p.add_argument("--samples", type=int, default=5)
    p.add_argument("--moves", nargs="+", default=list(PROMPTS), choices=list(PROMPTS))
    p.add_argument("--transition", type=int, default=5, help="slerp frames each side (default 5 at 30 fps)")
    p.add_argument("--reference", choices=("real", "synthetic"), default="real",
                   help="MPD's reference: the held-out CMU takes (default) or synthetic dances")
    p.add_argument("--references", type=int, default=8, help="with --reference synthetic: how many (default 8)")
    p.add_argument("--json", type=Path, help="write every value here")
    p.add_argument("--date", default=datetime.date.today().isoformat())
    p.add_argument("--readme", action="store_true")
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    result = run(args)
    text, line = report(result, args, time.perf_counter() - t0)
    print(text)
    if args.json:
        from dance_core import write_text

        write_text(args.json, json.dumps(result, indent=1, default=float))
    if args.readme:
        write_section("claims-tm2d", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
