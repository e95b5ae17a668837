"""TM2D's second claim as its own experiment: training on text as well costs no music-only quality.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/claims_tm2d_music.py [--seeds 5] [--steps 7000]
        [--runs runs/claims-tm2d-music] [--samples 3] [--seconds 30] [--json OUT] [--readme]

Two arms of ``tm2d-small``, ``--seeds`` training seeds each (recipe ``seed=0..N-1``), both from one VQ-VAE
(``--vqvae``: by default ``runs/tm2d-real2`` at step 3000, the one bundled until 2 Dec 2026, whose successor
adds a position loss; its weights and normalization statistics through
``training.init``), with the same music-dance pairs (real moves: the ``mocap`` option, the held-out takes
left out), steps, batch (32) and learning rate (5e-4); only the audio encoder and the prior train:

- **text**: the pairs and the 960 ``synthetic-moves`` text clips, as the bundled weights were trained;
- **music**: the pairs alone, ``model.head.text_stream=null``.

Each finished run is kept under ``--runs``/ARM-sSEED (a run whose ``model.safetensors`` exists is not
trained again, its ``scores.json`` not scored again; a ``SOURCE`` file there names a run trained elsewhere
with the same recipe and seed and copied in). Each run composes music only (``dance compose``, as
the bundled model composes: grounded, beat-aligned) ``--samples`` dances of the first ``--seconds`` of each
fixture song, and is scored with ``benchmarks/realism.py``'s measures: the realism distance of the window
statistics to the held-out CMU takes (× the real scale: the distance between the takes' halves), the
statistics whose median lies in the real 10-90 % range, body locking (the body's own accents on the
song's beats) beside its wrong-tempo control, and mean joint speed and jerk over the held-out takes'.

The rule, stated before the run (``RULE``): with 95 % percentile-bootstrap intervals over the training
seeds (``claims_protocol.difference``, the arms resampled independently), text training **keeps**
music-only quality when the interval of distance(text) − distance(music), in units of the real scale,
lies below ``+DISTANCE_MARGIN`` and that of locking(text) − locking(music) above ``-LOCKING_MARGIN``
(non-inferiority); it **does not** when either interval lies wholly beyond its margin; inconclusive
otherwise. The margins: a tenth of the distance between two halves of the same real takes (a difference
no one could see against real dance's own variation), and 0.05 locking (the smallest locking
``dance_quality.py`` tells from a wrong-tempo control).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from claims_protocol import ci, difference, pm
from readme_section import write_section

ROOT = Path(__file__).resolve().parents[1]
MOCAP = ROOT / ".." / "shared" / "mocap" / "cmu-dance"  # read in place, never committed
SONGS = ROOT / ".." / "shared" / "fixtures" / "audio"
VQVAE = ROOT / "runs" / "tm2d-real2-step3000.safetensors"
ARMS = ("text", "music")
DISTANCE_MARGIN = 0.10  # × the real scale
LOCKING_MARGIN = 0.05
RULE = (f"text training keeps music-only quality when the 95 % percentile-bootstrap interval over training seeds of "
        f"realism distance(text) − distance(music), in units of the real scale, lies below +{DISTANCE_MARGIN:g} and "
        f"that of body locking(text) − locking(music) above −{LOCKING_MARGIN:g} (non-inferiority margins: a tenth of "
        f"the distance between two halves of the same held-out real takes; the smallest locking told from a "
        f"wrong-tempo control); does not hold when either interval lies wholly beyond its margin; inconclusive "
        f"otherwise")
PAIRS = ("{plugin: synthetic-dance, songs: 96, seconds: 30, bpm: [70, 180], motion_fps: 60, dance_to_tracker: flux, "
         "keep_texts: false, mocap: %s, mocap_exclude: ['salsa_6?_09.bvh', 'salsa_6?_10.bvh', 'modern_05_1?.bvh']}")
TEXTS = "{plugin: synthetic-moves, clips: 960, seconds: [4.5, 9.0], motion_fps: 60}"


def train_sets(arm: str, seed: int, steps: int, vqvae: Path, mocap: Path) -> list[str]:
    """The ``--set`` overrides of one run: the arm's data, the VQ-VAE to start from, the prior stage only."""
    data = [PAIRS % mocap.resolve()] + ([TEXTS] if arm == "text" else [])
    sets = [f"data.dataset.datasets=[{', '.join(data)}]", f"seed={seed}",
            f"training.init={{checkpoint: {vqvae.resolve()}, weights: [head.tokenizer.], stats: true}}",
            f"training.stages=[{{name: prior, steps: {steps}, trainable: [encoder., head.prior.], lr: 5.0e-4, "
            f"batch_size: 32}}]"]
    return sets + (["model.head.text_stream=null"] if arm == "music" else [])


def train(out: Path, sets: list[str]) -> float:
    """Train one run into ``out`` unless its ``model.safetensors`` exists (a partial run is started again);
    the minutes it took (0 when skipped)."""
    if (out / "model.safetensors").exists():
        return 0.0
    t0 = time.time()
    cmd = [sys.executable, "-m", "dance_core.cli.main", "-q", "train", "tm2d-small", "-o", str(out), "--overwrite",
           *[a for s in sets for a in ("--set", s)]]
    subprocess.run(cmd, check=True, cwd=ROOT)
    return (time.time() - t0) / 60


def real_reference(mocap: Path) -> dict:
    """The held-out takes' window statistics, the real scale and mean speed and jerk."""
    from realism import HELD_OUT, real_scale, real_takes, stats

    from dance_core.evaluation import smoothness

    takes = real_takes(mocap)
    missing = [n for n in HELD_OUT if n not in takes]
    if missing:
        sys.exit(f"{mocap}: held-out takes missing: {', '.join(missing)}")
    held = [takes[n] for n in HELD_OUT]
    motion = [smoothness(np.asarray(m.positions(), np.float64), m.fps) for m in held]
    return {"windows": np.concatenate([stats(m) for m in held]), "scale": real_scale(held),
            "speed": float(np.mean([v["speed"] for v in motion])), "jerk": float(np.mean([v["jerk"] for v in motion]))}


def score_run(model: Path, arm: str, real: dict, songs: list[Path], beats: dict, samples: int, seconds: float) -> dict:
    """Compose music-only dances with one run's weights and score them against the real reference."""
    from realism import compose, locking_of, row, stats

    from dance_core.evaluation import smoothness

    sets = [f"compose.checkpoint={model.resolve()}"] + (["model.head.text_stream=null"] if arm == "music" else [])
    windows, locks, speed, jerk = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for song in songs:
            for m in compose("tm2d-small", song, Path(tmp) / song.stem, samples, seconds, *sets):
                windows.append(stats(m))
                locks.append(locking_of(m, beats[song.stem][beats[song.stem] < m.duration]))
                s = smoothness(np.asarray(m.positions(), np.float64), m.fps)
                speed.append(s["speed"])
                jerk.append(s["jerk"])
    r = row(arm, np.concatenate(windows), real["windows"], real["scale"], locks)
    return {"distance": r["distance"], "ratio": r["ratio"], "inside": r["inside"], "outside": r["outside"],
            "locking": r["locking"], "control": r["control"], "speed": float(np.mean(speed)) / real["speed"],
            "jerk": float(np.mean(jerk)) / real["jerk"], "dances": len(windows)}


def non_inferior(interval, margin: float, higher_is_worse: bool = True) -> str:
    """Read one difference's interval against its non-inferiority margin: ``within`` when the whole interval
    lies on the good side of the margin, ``beyond`` when it lies wholly past it, ``straddles`` otherwise
    (``n/a`` without an interval). For a measure where higher is better the margin is at ``-margin``."""
    _, low, high = interval
    if low is None:
        return "n/a"
    worse_low, worse_high = (low, high) if higher_is_worse else (-high, -low)
    return "within" if worse_high < margin else "beyond" if worse_low > margin else "straddles"


def verdict(readings) -> str:
    """``holds`` when every reading is within its margin, ``does not hold`` when any is beyond,
    ``n/a`` when any has no interval, else ``inconclusive``."""
    readings = list(readings)
    if "n/a" in readings:
        return "n/a"
    if "beyond" in readings:
        return "does not hold"
    return "holds" if all(r == "within" for r in readings) else "inconclusive"


def judge(scores: dict) -> dict:
    """The intervals of the judged differences, their readings and the verdict, from ``{arm: [score]}``."""
    values = {arm: {k: [s[k] for s in scores[arm]] for k in ("ratio", "locking")} for arm in ARMS}
    dist = difference(values["text"]["ratio"], values["music"]["ratio"])
    lock = difference(values["text"]["locking"], values["music"]["locking"])
    readings = {"distance": non_inferior(dist, DISTANCE_MARGIN), "locking": non_inferior(lock, LOCKING_MARGIN, False)}
    return {"distance": dist, "locking": lock, "readings": readings, "verdict": verdict(readings.values())}


def trained(score: dict) -> str:
    """Where a run was trained, for the table: its minutes here, or the run it was copied from."""
    source = score.get("source", "trained here")
    return f"{score['minutes']:.0f} min" if source == "trained here" else source


def report(result: dict, args, wall: float, load: str) -> tuple[str, str]:
    """The README section (command, per-seed table, means, intervals, rule, verdict) and its verdict line."""
    import torch

    scores, j = result["scores"], result["judged"]
    done = {arm: len(scores[arm]) for arm in ARMS}
    cmd = "OMP_NUM_THREADS=1 nice -n 15 .venv/bin/python benchmarks/claims_tm2d_music.py --readme"
    if args.seeds != 5 or args.steps != 7000:
        cmd += f" --seeds {args.seeds} --steps {args.steps}"
    this = (f"{wall / 60:.0f} min in this invocation, which trained {result['trained']} runs" if result["trained"]
            else "this invocation trained nothing (every run was scored before)")
    lines = [f"Command: `{cmd}`; {args.date}; {platform.machine()}, {os.cpu_count()} cores, load average {load} at "
             f"the end, 1 torch thread, torch {torch.__version__}; {this} (each run's training time in the table). "
             f"Runs: "
             f"{args.runs}/ARM-sSEED; VQ-VAE {args.vqvae.name} (weights and normalization statistics); prior stage "
             f"{args.steps} steps, batch 32, lr 5e-4; seeds finished: text {done['text']}, music {done['music']} of "
             f"{args.seeds}. Dances: {args.samples} per fixture song ({', '.join(result['songs'])}), first "
             f"{args.seconds:g} s, music only, `dance compose` (grounded, beat-aligned). Real scale (halves of the "
             f"held-out takes): {result['scale']:.1f}.", "",
             "| arm | seed | realism distance (× real scale) | statistics in range | outside | body locking | "
             "wrong-tempo control | speed ×real | jerk ×real | trained |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for arm in ARMS:
        for s in scores[arm]:
            lines.append(f"| {arm} | {s['seed']} | {s['distance']:.1f} ({s['ratio']:.2f}x) | {s['inside']}/11 | "
                         f"{', '.join(s['outside']) or '–'} | {s['locking']:.2f} | {s['control']:.2f} | "
                         f"{s['speed']:.2f} | {s['jerk']:.2f} | {trained(s)} |")
    for arm in ARMS:
        col = {k: [s[k] for s in scores[arm]] for k in ("distance", "ratio", "inside", "locking", "control", "speed",
                                                        "jerk")}
        lines.append(f"| **{arm}, mean ± sd** | {done[arm]} seeds | {pm(col['distance'])} ({pm(col['ratio'])}) | "
                     f"{pm(col['inside'])} | | "
                     f"{pm(col['locking'])} | {pm(col['control'])} | {pm(col['speed'])} | {pm(col['jerk'])} | |")
    lines += ["", f"Text − music, 95 % bootstrap interval over seeds: realism distance (× real scale) "
              f"{ci(j['distance'])} ({j['readings']['distance']} the +{DISTANCE_MARGIN:g} margin); body locking "
              f"{ci(j['locking'])} ({j['readings']['locking']} the −{LOCKING_MARGIN:g} margin).", ""]
    seeds = f"{min(done.values())} of {args.seeds} seeds per arm" if min(done.values()) < args.seeds else \
        f"{args.seeds} seeds per arm"
    line = (f"- **TM2D, music-only quality** (training on text as well costs no music-only quality; `tm2d-small`, "
            f"text-trained against music-only, same VQ-VAE, data, steps and batch): realism distance × real scale "
            f"text {pm([s['ratio'] for s in scores['text']])} vs music {pm([s['ratio'] for s in scores['music']])}, "
            f"text − music {ci(j['distance'])}; body locking text {pm([s['locking'] for s in scores['text']])} vs "
            f"music {pm([s['locking'] for s in scores['music']])}, text − music {ci(j['locking'])}; {seeds}, "
            f"{args.samples} dances × {len(result['songs'])} fixture songs per run: **{j['verdict']}**. Rule: "
            f"{RULE}. (benchmarks/claims_tm2d_music.py; its section \"Music-only quality\")")
    return "\n".join(lines + [line]), line


def run(args) -> dict:
    """Train what is missing and score every finished run, seed by seed (both arms of a seed before the next)."""
    from realism import song_beats

    songs = sorted(args.music or SONGS.glob("*.ogg"))
    real = real_reference(args.mocap)
    beats = {song.stem: song_beats(song) for song in songs}
    from dance_core import write_text

    scores, trained = {arm: [] for arm in ARMS}, 0
    for seed in range(args.seeds):
        for arm in ARMS:
            out = args.runs / f"{arm}-s{seed}"
            path = out / "scores.json"
            if not path.exists() and args.cached_only:
                continue
            if not path.exists():
                minutes = train(out, train_sets(arm, seed, args.steps, args.vqvae, args.mocap))
                trained += minutes > 0
                s = score_run(out / "model.safetensors", arm, real, songs, beats, args.samples, args.seconds)
                source = out / "SOURCE"  # a run trained elsewhere with this recipe and seed, copied in
                s |= {"seed": seed, "minutes": minutes,
                      "source": source.read_text(encoding="utf-8").strip() if source.exists() else "trained here"}
                write_text(path, json.dumps(s, indent=1, default=float))
            scores[arm].append(json.loads(path.read_text()))
            s = scores[arm][-1]
            print(f"{arm} seed {seed}: distance {s['distance']:.2f} ({s['ratio']:.2f}x), in range {s['inside']}/11, "
                  f"locking {s['locking']:.2f} (control {s['control']:.2f}), speed {s['speed']:.2f}, "
                  f"jerk {s['jerk']:.2f}; trained in {s['minutes']:.1f} min", flush=True)
    return {"scores": scores, "scale": real["scale"], "songs": [s.stem for s in songs], "trained": trained}


def main(argv: list[str] | None = None) -> int:
    """Run the experiment (resumable), print the section, optionally write it into benchmarks/README.md."""
    import torch

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--steps", type=int, default=7000, help="prior steps per run (default 7000, as bundled)")
    p.add_argument("--runs", type=Path, default=Path("runs/claims-tm2d-music"))
    p.add_argument("--vqvae", type=Path, default=VQVAE, help="the VQ-VAE checkpoint both arms start from")
    p.add_argument("--mocap", type=Path, default=MOCAP)
    p.add_argument("--music", nargs="+", type=Path, help="songs (default: the fixture songs)")
    p.add_argument("--samples", type=int, default=3)
    p.add_argument("--seconds", type=float, default=30.0)
    p.add_argument("--cached-only", action="store_true", help="report the scored runs, train nothing new")
    p.add_argument("--json", type=Path, help="write every value here")
    p.add_argument("--date", default=datetime.date.today().isoformat())
    p.add_argument("--readme", action="store_true")
    args = p.parse_args(argv)
    for path, what in ((args.vqvae, "--vqvae"), (args.mocap, "--mocap")):
        if not path.exists():
            sys.exit(f"{path}: {what} not found")
    if args.seeds < 1 or args.steps < 1 or args.samples < 1:
        sys.exit("--seeds, --steps and --samples must be at least 1")
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    result = run(args)
    result["judged"] = judge(result["scores"])
    text, _ = report(result, args, time.perf_counter() - t0, f"{os.getloadavg()[0]:.1f}")
    print(text)
    if args.json:
        from dance_core import write_text

        write_text(args.json, json.dumps(result, indent=1, default=float))
    if args.readme:
        write_section("claims-tm2d-music", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
