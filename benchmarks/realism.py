"""Realism against real dance: window statistics and their Fréchet distance to held-out CMU dance takes,
and beat locking from the body's own movement, for the bundled models, the synthetic dancer and controls
that must fail.

    .venv/bin/python benchmarks/realism.py [--mocap ../shared/mocap/cmu-dance] [--songs DIR]
        [--models default tm2d-small] [--raw default] [--samples 3] [--seconds 30] [--json FILE]

Reference: the CMU takes held out of every training recipe (``HELD_OUT``: both partners of salsa takes
09 and 10, modern takes 10-12), retargeted onto ``dance24`` at 30 fps by the ``mocap`` dataset. Its
scale: the distance between the first and second halves of those takes, and from the other CMU takes
(the training pool) to them. Rows: every bundled model on every fixture song (``--samples`` dances each,
composed by ``dance compose``), the synthetic dancer, and the controls: a still figure, a rigid T-pose
figure bouncing 4 cm down on every beat and swaying (the statue that passed the old benchmark), and
the synthetic dancer and the real-moves choreography (real takes chained onto the songs' beats) shifted
half a beat off their music (locking must fail). ``--raw`` models are also composed with
``compose.beat_align=false``: the model's own timing, before compose moves its accents onto the beats.
*Spread*: the mean distance between two dances of one song (standardised mean statistics), beside the
same between two takes of one real dancer (CMU subjects 05, 60, 61; their first ``--seconds``).
*FID_k*: ``dance evaluate``'s ``fid-k`` (AIST++'s kinetic features) of each set's 4-s windows (every 2 s)
against the held-out takes'; its scale row: the takes' first halves against their second halves. Measures:
:mod:`dance_core.evaluation.realism`.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FPS = 30.0
HELD_OUT = ("salsa_60_09", "salsa_61_09", "salsa_60_10", "salsa_61_10", "modern_05_10", "modern_05_11",
            "modern_05_12")
HOP = 0.5
MOCAP = ROOT / ".." / "shared" / "mocap" / "cmu-dance"  # read in place, never committed


def stats(motion) -> np.ndarray:
    """Window statistics of a skeletal motion."""
    from dance_core.evaluation import window_statistics

    return window_statistics(motion.positions(), motion.fps, motion.skeleton.names, hop=HOP)


def real_takes(folder: Path) -> dict:
    """Every CMU take on dance24 at 30 fps (cached by the mocap dataset)."""
    from dance_core import DatasetContext, get_registry

    dataset = get_registry().create("dataset", "mocap", {"path": str(folder)}, DatasetContext(fps=FPS))
    clips = dataset.clips()
    return {c.name: c.motion.skeleton_motion for c in clips}


def halves(motion) -> tuple:
    """The first and second half of a motion."""
    n = motion.n_frames // 2
    return motion.crop(0, n), motion.crop(n)


def real_scale(held: list) -> float:
    """The real scale: the realism distance between the first and second halves of the held-out takes (both
    ways, averaged)."""
    from dance_core.evaluation import realism_distance

    first = np.concatenate([stats(halves(m)[0]) for m in held])
    second = np.concatenate([stats(halves(m)[1]) for m in held])
    return (realism_distance(first, second) + realism_distance(second, first)) / 2


def statue(beats: np.ndarray, seconds: float, fps: float = FPS):
    """dance24 rigid in its T-pose, 4 cm down on every beat and swaying 10 cm every 2 s."""
    from dance_core import Motion
    from dance_core.motion import dance24

    skel = dance24()
    t = np.arange(int(seconds * fps)) / fps
    root = np.tile(skel.offsets[0], (len(t), 1))
    period = float(np.median(np.diff(beats))) if len(beats) > 1 else 0.5
    root[:, 1] -= 0.04 * (1 + np.cos(2 * np.pi * (t - beats[0]) / period)) / 2
    root[:, 0] += 0.1 * np.sin(2 * np.pi * t / 2.0)
    return Motion(skel, fps, root, np.tile([0.0, 0, 0, 1], (len(t), len(skel), 1)))


def still(seconds: float, fps: float = FPS):
    """dance24 standing still in its rest pose."""
    from dance_core import Motion
    from dance_core.motion import dance24

    skel = dance24()
    n = int(seconds * fps)
    return Motion(skel, fps, np.tile(skel.offsets[0], (n, 1)), np.tile([0.0, 0, 0, 1], (n, len(skel), 1)))


def synthetic(n: int, seconds: float) -> list:
    """``n`` dances of the synthetic dancer with their beat times."""
    from dance_core.synth import make_clip

    out = []
    for i in range(n):
        clip = make_clip(i, seed=11, seconds=seconds, bpm=(80.0, 140.0), rate=8000, fps=FPS)
        out.append((clip.motion.skeleton_motion, np.asarray(clip.meta["beats"], np.float64)))
    return out


def song_beats(song: Path) -> np.ndarray:
    """Beat times of a song from dance-audio's default tracker."""
    from dance_audio.beats import track_beats
    from dance_core import get_registry, load_audio

    return np.asarray(track_beats(load_audio(song, get_registry()), tracker="flux").times, np.float64)


def compose(model: str, song: Path, out: Path, samples: int, seconds: float, *sets: str) -> list:
    """Dances of a bundled model for a song (``dance compose``, ``--set`` each of ``sets``), read back."""
    from dance_core.api import read_motion

    cmd = [sys.executable, "-m", "dance_core.cli.main", "-q", "compose", model, "--music", str(song), "-o", str(out),
           "--samples", str(samples), "--set", f"compose.seconds={seconds}", *[a for v in sets for a in ("--set", v)]]
    subprocess.run(cmd, check=True, cwd=ROOT)
    return [read_motion(p, "bvh").skeleton_motion.resample(FPS) for p in sorted(out.glob(f"{song.stem}*.bvh"))]


def real_moves(song: Path, mocap: Path, out: Path, dances: int, seconds: float) -> list:
    """Dances chained from the training pool's real moves to a song (``dance synth --music --mocap``, the
    held-out takes left out), its first ``seconds``, read back."""
    from dance_core.api import read_motion

    cmd = [sys.executable, "-m", "dance_core.cli.main", "-q", "synth", "--out", str(out), "--music", str(song),
           "--dances", str(dances), "--fps", str(FPS), "--mocap", str(mocap), "--mocap-exclude",
           *[f"{n}.bvh" for n in HELD_OUT]]
    subprocess.run(cmd, check=True, cwd=ROOT)
    motions = [read_motion(p, "bvh").skeleton_motion for p in sorted(out.glob(f"{song.stem}*.bvh"))]
    return [m.crop(0, int(seconds * FPS)) for m in motions]


def spread(groups: list[list[np.ndarray]], reference: np.ndarray) -> float:
    """How different dances of one group (samples of one song, takes of one dancer) are: the mean distance
    between the mean window statistics of two dances of a group, standardised by the reference."""
    sd = np.where(reference.std(0) > 1e-9, reference.std(0), 1.0)
    groups = [[w for w in g if len(w)] for g in groups]  # a take shorter than one window has no statistics
    dists = [np.linalg.norm((a.mean(0) - b.mean(0)) / sd) for g in groups
             for i, a in enumerate(g) for b in g[i + 1:]]
    return float(np.mean(dists)) if dists else float("nan")


def row(name: str, windows: np.ndarray, reference: np.ndarray, scale: float, locking=None, groups=None) -> dict:
    """One table row: distance, its ratio to the real scale, per-statistic medians, locking, and how much
    the dances of one song differ (``groups``)."""
    from dance_core.evaluation import STATISTICS, realism_distance

    lo, hi = np.percentile(reference, 10, axis=0), np.percentile(reference, 90, axis=0)
    med = np.median(windows, axis=0)
    inside = [bool(lo[k] <= med[k] <= hi[k]) for k in range(len(STATISTICS))]
    out = {"name": name, "distance": realism_distance(windows, reference), "windows": len(windows),
           "medians": dict(zip(STATISTICS, med.round(3).tolist(), strict=True)), "inside": sum(inside),
           "outside": [s for s, ok in zip(STATISTICS, inside, strict=True) if not ok]}
    out["ratio"] = out["distance"] / scale
    if locking:
        out |= {k: float(np.nanmean([lk[k] for lk in locking])) for k in ("locking", "control", "accents_per_beat")}
    if groups:
        out["spread"] = spread(groups, reference)
    return out


def kinetic_fid(motions: list, reference: list, window: float = 4.0, hop: float = 2.0) -> float:
    """FID_k (AIST++'s kinetic features; ``dance evaluate``'s ``fid-k``) of the ``window``-second windows
    (every ``hop`` s) of motions against those of reference motions: whole takes are too few (7) for a
    covariance of 72 features; NaN with fewer than two windows on a side."""
    from dance_core import JointClip
    from dance_core.api import EvaluateOptions, evaluate

    def clips(ms: list, tag: str) -> list:
        out = []
        for m in ms:
            size, step = int(round(window * m.fps)), int(round(hop * m.fps))
            for start in range(0, m.n_frames - size + 1, step):
                w = m.crop(start, start + size)
                out.append(JointClip(f"{tag}{len(out)}", w.positions(), w.fps, list(w.skeleton.names)))
        return out

    if len(clips(motions, "g")) < 2 or len(clips(reference, "r")) < 2:
        return float("nan")

    report = evaluate(clips(motions, "g"), clips(reference, "r"), EvaluateOptions(metrics=["fid-k"]))
    return float(report.values().get("FID_k", float("nan")))


def locking_of(motion, beats) -> dict:
    """Body locking of one dance."""
    from dance_core.evaluation import body_locking

    return body_locking(motion.positions(), motion.fps, motion.skeleton.names, beats)


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and print its tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mocap", type=Path, default=MOCAP)
    parser.add_argument("--songs", type=Path, default=ROOT / ".." / "shared" / "fixtures" / "audio")
    parser.add_argument("--models", nargs="*", default=["default", "tm2d-small"])
    parser.add_argument("--raw", nargs="*", default=["default"],
                        help="models also composed with compose.beat_align=false (the model's own timing)")
    parser.add_argument("--samples", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    from dance_core.evaluation import STATISTICS

    started = time.time()
    takes = real_takes(args.mocap)
    missing = [n for n in HELD_OUT if n not in takes]
    if missing:
        sys.exit(f"{args.mocap}: held-out takes missing: {', '.join(missing)}")
    reference = np.concatenate([stats(takes[n]) for n in HELD_OUT])
    scale = real_scale([takes[n] for n in HELD_OUT])
    pool = np.concatenate([stats(m) for n, m in takes.items() if n not in HELD_OUT])
    dancers: dict[str, list[np.ndarray]] = {}
    for n, m in takes.items():  # takes of one dancer: CMU subject 05 (modern), 60 and 61 (salsa)
        dancers.setdefault(n.rsplit("_", 1)[0], []).append(stats(m.crop(0, int(args.seconds * FPS))))
    rows = [{"name": "real: first halves vs second halves (the scale)", "distance": scale, "ratio": 1.0,
             "windows": sum(len(stats(h)) for n in HELD_OUT for h in halves(takes[n])), "inside": len(STATISTICS),
             "outside": [], "medians": {},
             "spread": spread([g for g in dancers.values() if len(g) > 1], reference)},
            row("real: the other CMU takes (training pool)", pool, reference, scale)]
    held = [takes[n] for n in HELD_OUT]
    rows[0]["fid_k"] = kinetic_fid([halves(m)[0] for m in held], [halves(m)[1] for m in held])
    rows[1]["fid_k"] = kinetic_fid([m for n, m in takes.items() if n not in HELD_OUT], held)
    syn = synthetic(6, args.seconds)
    rows.append(row("synthetic dancer", np.concatenate([stats(m) for m, _ in syn]), reference, scale,
                    [locking_of(m, b) for m, b in syn]))
    rows[-1]["fid_k"] = kinetic_fid([m for m, _ in syn], held)
    shifted = [(m, b + 0.5 * float(np.median(np.diff(b)))) for m, b in syn]
    rows.append(row("control: synthetic dancer half a beat off", np.concatenate([stats(m) for m, _ in shifted]),
                    reference, scale, [locking_of(m, b) for m, b in shifted]))
    songs = sorted(p for p in args.songs.glob("*.ogg"))
    beats = {song.stem: song_beats(song) for song in songs}
    seconds = args.seconds
    statues = [statue(b[b < seconds], seconds) for b in beats.values()]
    rows.append(row("control: rigid T-pose bouncing on the beat", np.concatenate([stats(m) for m in statues]),
                    reference, scale, [locking_of(m, b[b < seconds]) for m, b in zip(statues, beats.values(),
                                                                                    strict=True)]))
    rows[-1]["fid_k"] = kinetic_fid(statues, held)
    rows.append(row("control: still figure", stats(still(seconds)), reference, scale))
    with tempfile.TemporaryDirectory() as tmp:
        # the choreography the bundled default learns from: real moves on each song's beats (dance synth --mocap)
        chained, locks, moved = [], [], []
        for song in songs:
            for m in real_moves(song, args.mocap, Path(tmp) / "real-moves", args.samples, seconds):
                chained.append(stats(m))
                moved.append((m, beats[song.stem][beats[song.stem] < m.duration]))
                locks.append(locking_of(*moved[-1]))
        rows.append(row(f"real-moves choreography, training pool ({len(chained)} dances)", np.concatenate(chained),
                        reference, scale, locks))
        rows[-1]["fid_k"] = kinetic_fid([m for m, _ in moved], held)
        off = [locking_of(m, b + 0.5 * float(np.median(np.diff(b)))) for m, b in moved]
        rows.append(row("control: real-moves choreography half a beat off", np.concatenate(chained), reference,
                        scale, off))
        for model, sets in [(m, ()) for m in args.models] + [(m, ("compose.beat_align=false",)) for m in args.raw]:
            dances, locks, groups, motions = [], [], [], []
            for song in songs:
                group = []
                for m in compose(model, song, Path(tmp) / model / str(len(sets)) / song.stem, args.samples, seconds,
                                 *sets):
                    motions.append(m)
                    group.append(stats(m))
                    locks.append(locking_of(m, beats[song.stem][beats[song.stem] < m.duration]))
                dances += group
                groups.append(group)
            label = f"{model}{', raw model (compose.beat_align=false)' if sets else ''}"
            rows.append(row(f"{label} ({len(dances)} dances on {len(songs)} fixture songs)", np.concatenate(dances),
                            reference, scale, locks, groups))
            rows[-1]["fid_k"] = kinetic_fid(motions, held)
    print(f"reference: {len(HELD_OUT)} held-out CMU takes, {len(reference)} windows of 4 s every {HOP} s; "
          f"{time.time() - started:.0f} s")
    print("| dancer | Fréchet distance | × real scale | statistics inside real 10-90 % | outside | body locking "
          "| wrong-tempo control | accents per beat | spread (one song / one dancer) | FID_k |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        lk = (f"{r['locking']:.2f} | {r['control']:.2f} | {r['accents_per_beat']:.2f}" if "locking" in r
              else "– | – | –")
        sp = f"{r['spread']:.2f}" if "spread" in r else "–"
        fid = f"{r['fid_k']:.1f}" if np.isfinite(r.get("fid_k", float("nan"))) else "–"
        print(f"| {r['name']} | {r['distance']:.1f} | {r['ratio']:.1f} | {r['inside']}/{len(STATISTICS)} | "
              f"{', '.join(r['outside']) or '–'} | {lk} | {sp} | {fid} |")
    lo, med, hi = (np.percentile(reference, q, axis=0) for q in (10, 50, 90))
    print("\n| statistic | real 10 % | real median | real 90 % | " + " | ".join(r["name"].split(" (")[0]
                                                                               for r in rows[1:]) + " |")
    print("|---" * (4 + len(rows) - 1) + "|")
    for k, s in enumerate(STATISTICS):
        print(f"| {s} | {lo[k]:.2f} | {med[k]:.2f} | {hi[k]:.2f} | "
              + " | ".join(f"{r['medians'].get(s, float('nan')):.2f}" for r in rows[1:]) + " |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
