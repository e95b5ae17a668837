"""The claims benchmark: every model family's small preset, trained with one budget on the synthetic
choreography, scored with ``dance_core.evaluation`` in the papers' table style.

    .venv/bin/python benchmarks/claims.py [--steps 400] [--readme]

Data: core's ``synthetic-dance`` dataset (seed 0): synthesized songs with a beat-locked SMPL-24
dancer at 20 fps, learned in Transflower's motion representation (root ground deltas + exponential
maps). Training songs are songs 0-11 (12 s each; each recipe holds out its own validation fraction
of them); test songs are songs 12-17 of the same generator, so no test song is seen in training (a
split by song). Every family gets the same steps, batch size and optimizer (AdamW 1e-3, cosine with
30 warm-up steps, gradient clip 1.0), composes every test song once from the rest pose and writes
BVH, which is read back through the BVH format and forward kinematics like ``dance evaluate`` does.

Rows: ground truth (the test songs' real dances), shuffled music (the same dances paired with
another test song's beats), untrained (transflower-small after 1 step), then one row per family.
FID_k, FID_g, Div_k, Div_g and FMD compare with the real dances of the *training* songs; the beat
metrics use each test song's annotated beats. A family whose recipe is not installed, or that fails, is listed with
the reason instead of numbers. The two DanceRevolution rows also compose 60 s versions of the test
songs for the long-horizon freezing claim. ``--readme`` writes the result into benchmarks/README.md
between the ``claims`` markers.
"""

from __future__ import annotations

import argparse
import platform
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from readme_section import write_section

ROOT = Path(__file__).resolve().parents[1]
FPS = 20.0
TRAIN_SONGS = 12
METRICS = ["fid-k", "fid-g", "div-k", "div-g", "bas-bailando", "freezing", "fmd", "beat-offset", "pfc"]
DATASET = {"seed": 0, "bpm": (80.0, 140.0), "rate": 22050}
SAME_BUDGET = [
    "training.optimizer.lr=1.0e-3",
    "training.optimizer.weight_decay=0.0",
    "training.lr_schedule={plugin: cosine, warmup: 30}",
    "training.grad_clip=1.0",
    "training.val_every=100000",
    "training.checkpoint_every=100000",
    f"data.dataset={{plugin: synthetic-dance, songs: {TRAIN_SONGS}, seconds: 12}}",
    "motion={plugin: rotations, rotation: expmap, root: deltas}",
    "data.val_fraction=0.15",
    "compose.samples=1",
    "compose.formats=[bvh]",
    "compose.seed_motion=rest",
]
SMALL_TRANSFORMER = [  # transflower-small's encoder sizes, for the baseline that shares its encoder
    "model.encoder.motion_past=40",
    "model.encoder.cond_past=40",
    "model.encoder.cond_future=10",
    "model.encoder.dim=64",
    "model.encoder.motion={layers: 1, heads: 4, ffn: 128}",
    "model.encoder.music={layers: 1, heads: 4, ffn: 128}",
    "model.encoder.crossmodal={layers: 2, heads: 4, ffn: 128}",
    "model.encoder.latent=queries",
]
MOGLOW_SMALL = [
    "model.encoder.hidden=64",
    "model.encoder.layers=1",
    "model.encoder.dim=64",
    "model.head.steps=8",
    "model.head.coupling={dim: 64, layers: 1, heads: 4}",
]
TEACHER_FORCING = ["training.schedules.auto_condition={plugin: constant, value: 0}"]
#: (row label, recipe, extra overrides, compose the 60 s test songs too)
FAMILIES = [
    ("Transflower (transflower-small)", "transflower-small", [], False),
    (
        "AI Choreographer (transflower-small encoder, regression head)",
        "aichoreographer",
        [*SMALL_TRANSFORMER, "model.head.hidden=64"],
        False,
    ),
    ("MoGlow (moglow at small sizes)", "moglow", MOGLOW_SMALL, False),
    ("DanceRevolution (dancerevolution-small, curriculum)", "dancerevolution-small", [], True),
    ("DanceRevolution, pure teacher forcing", "dancerevolution-small", TEACHER_FORCING, True),
    ("Cross-breed (cross-breed-small)", "cross-breed-small", [], False),
    ("TM2D (tm2d-small)", "tm2d-small", [], False),
]
COLUMNS = [
    ("FID_k", "FID_k ↓"),
    ("FID_g", "FID_g ↓"),
    ("Div_k", "Div_k"),
    ("Div_g", "Div_g"),
    ("BAS_bailando", "BAS ↑"),
    ("PFF", "PFF % ↓"),
    ("AUC_f", "AUC_f ↓"),
    ("FMD", "FMD ↓"),
    ("beat_offset_mean", "beat offset (s) ↓"),
    ("PFC", "PFC ↓"),
]


@dataclass
class Row:
    """One table row: metric values (None: not run), training time, generation speed, a note."""

    label: str
    values: dict | None = None
    train_s: float | None = None
    speed: float | None = None
    note: str = ""
    long_values: dict | None = None


def dance_clip(index: int, seconds: float):
    """Song ``index`` of the synthetic-dance generator (its audio, beats and SMPL dancer)."""
    from dance_core.data.synthetic_dance import make_clip

    return make_clip(index, seconds=seconds, fps=FPS, **DATASET)


def to_clip(source, beats: bool):
    """A synthetic-dance source as a JointClip (positions by forward kinematics, metres)."""
    from dance_core.protocols import JointClip

    motion = source.motion.skeleton_motion
    music = np.asarray(source.meta["beats"]) if beats else None
    return JointClip(source.name, motion.positions(), motion.fps, list(motion.skeleton.names), music)


def synthetic_sets(out: Path, songs: int, seconds: float):
    """Write the test songs (WAV, BVH, beats) under ``out``; return (test GT clips, song paths)."""
    from dance_core.data.synthetic_dance import write_clip

    sources = [dance_clip(i, seconds) for i in range(TRAIN_SONGS, TRAIN_SONGS + songs)]
    paths = [write_clip(out, s)[0] for s in sources]
    return [to_clip(s, beats=True) for s in sources], paths


def training_clips():
    """The real dances of the training songs (the reference set of the motion metrics)."""
    return [to_clip(dance_clip(i, 12.0), beats=False) for i in range(TRAIN_SONGS)]


def score(generated, reference, metrics=METRICS):
    """The metrics as a flat dict (None where a metric could not run) and the skip reasons."""
    from dance_core.evaluation.report import evaluate

    report = evaluate(generated, reference, metrics)
    values = report.values()
    return {key: values.get(key) for key, _ in COLUMNS}, report.skipped


def train_family(recipe_name: str, extra: list[str], steps: int, batch: int, out: Path):
    """Train one family with the shared budget; returns (recipe, checkpoint, seconds)."""
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    recipe = load_recipe(recipe_name, [*SAME_BUDGET, f"training.steps={steps}", f"training.batch_size={batch}", *extra])
    t0 = time.perf_counter()
    result = train(recipe, out=str(out / "run"), quiet=True)
    return recipe, result.checkpoint, time.perf_counter() - t0


def generate(recipe, checkpoint, songs, test_clips, out: Path):
    """Compose every song; returns (clips read back from BVH with the songs' beats, frames/s)."""
    from dance_core.compose import compose
    from dance_core.evaluation.loading import load_clips
    from dance_core.registry import get_registry

    t0 = time.perf_counter()
    compose(recipe, music=[str(s) for s in songs], checkpoint=str(checkpoint), out_dir=str(out), quiet=True)
    seconds = time.perf_counter() - t0
    clips = load_clips(out, get_registry(), suffixes=[".bvh"])
    beats = {c.name: c.music_beats for c in test_clips}
    for clip in clips:
        clip.music_beats = beats[clip.name]
    return clips, sum(len(c.positions) for c in clips) / seconds


def fmt(value) -> str:
    """A table cell."""
    if value is None:
        return "n/a"
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:,.0f}"


def table(rows: list[Row]) -> list[str]:
    """The markdown table of every row."""
    header = ["model", *[c for _, c in COLUMNS], "train (s)", "generation (frames/s)", "note"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        cells = [fmt(r.values.get(k)) for k, _ in COLUMNS] if r.values else ["—"] * len(COLUMNS)
        extra = [fmt(r.train_s), f"{r.speed:,.0f}" if r.speed else "—", r.note]
        lines.append("| " + " | ".join([r.label, *cells, *extra]) + " |")
    return lines


def verdict(better: bool, equal: bool) -> str:
    """``holds`` / ``does not hold``."""
    return "holds" if better else "does not hold (equal)" if equal else "does not hold"


def freezes_less(a: dict, b: dict) -> str:
    """Compare freezing: PFF first, AUC_f (freezing at other thresholds) when PFF ties."""
    p, q, x, y = a.get("PFF"), b.get("PFF"), a.get("AUC_f"), b.get("AUC_f")
    if None in (p, q, x, y):
        return "freezing could not be measured"
    better, equal = p < q or (p == q and x < y), p == q and x == y
    return f"PFF {fmt(p)} % vs {fmt(q)} %, AUC_f {fmt(x)} vs {fmt(y)}: {verdict(better, equal)}"


def claims(rows: list[Row], long_seconds: float) -> list[str]:
    """Whether the papers' central claims hold here, with the numbers."""
    by = {r.label.split(" (")[0].split(",")[0] + (" TF" if "teacher" in r.label else ""): r for r in rows}
    out = []
    tf, aic = by.get("Transflower"), by.get("AI Choreographer")
    if tf and aic and tf.values and aic.values:
        a, b = tf.values["FMD"], aic.values["FMD"]
        out.append(
            f"- **Transflower** (the flow head beats the deterministic head on FMD and freezes less): "
            f"FMD {fmt(a)} vs {fmt(b)}: {verdict(a < b, a == b)}; {freezes_less(tf.values, aic.values)}."
        )
    else:
        out.append("- **Transflower**: cannot be checked here (a row did not run).")
    cur, tforce = by.get("DanceRevolution"), by.get("DanceRevolution TF")
    if cur and tforce and cur.long_values and tforce.long_values:
        out.append(
            f"- **DanceRevolution** (curriculum training freezes less than pure teacher forcing over "
            f"{long_seconds:g} s): {freezes_less(cur.long_values, tforce.long_values)}."
        )
    else:
        out.append("- **DanceRevolution**: cannot be checked here (a row did not run).")
    return out


def main() -> None:
    """Run every row, print the tables and the claims, optionally write them into the README."""
    import torch

    from dance_core.registry import get_registry

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=400, help="training steps for every family (default 400)")
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    parser.add_argument("--test-songs", type=int, default=6)
    parser.add_argument("--test-seconds", type=float, default=20.0, help="length of the test songs")
    parser.add_argument("--long-seconds", type=float, default=60.0, help="length for the freezing claim")
    parser.add_argument("--out", default=str(ROOT / "runs" / "claims"))
    parser.add_argument("--only", nargs="*", metavar="RECIPE", help="recipes to run (default: all)")
    parser.add_argument("--readme", action="store_true", help="write the result into benchmarks/README.md")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    out = Path(args.out)
    started = time.perf_counter()
    reference = training_clips()
    test_gt, songs = synthetic_sets(out / "test", args.test_songs, args.test_seconds)
    long_gt, long_songs = synthetic_sets(out / "long", args.test_songs, args.long_seconds)
    values, skipped = score(test_gt, reference)
    rows = [Row("Ground truth (test songs' real dances)", values)]
    shuffled = [replace(c, music_beats=test_gt[(k + 1) % len(test_gt)].music_beats) for k, c in enumerate(test_gt)]
    rows.append(Row("Shuffled music (real dances, another song's beats)", score(shuffled, reference)[0]))
    recipes = set(get_registry().names("recipe"))
    plan = [("Untrained (transflower-small, 1 step)", "transflower-small", [], False, 1)]
    plan += [(label, name, extra, long, args.steps) for label, name, extra, long in FAMILIES]
    for label, name, extra, long, steps in plan:
        if args.only and name not in args.only:
            continue
        if name not in recipes:
            rows.append(Row(label, note=f"not available: no recipe `{name}` installed"))
            continue
        where = out / f"{len(rows):02d}-{name}"
        try:
            recipe, ckpt, train_s = train_family(name, extra, steps, args.batch_size, where)
            clips, speed = generate(recipe, ckpt, songs, test_gt, where / "dances")
            row = Row(label, score(clips, reference)[0], train_s, speed)
            if long:
                long_clips, _ = generate(recipe, ckpt, long_songs, long_gt, where / "dances-long")
                row.long_values = score(long_clips, reference, ["freezing"])[0]
                row.note = (
                    f"{args.long_seconds:g} s: PFF {fmt(row.long_values['PFF'])} %, "
                    f"AUC_f {fmt(row.long_values['AUC_f'])}"
                )
        except Exception as exc:  # a family that cannot run is reported, never faked
            row = Row(label, note=f"failed: {type(exc).__name__}: {str(exc).splitlines()[0][:160]}")
        rows.append(row)
        print(f"done: {label} ({time.perf_counter() - started:.0f} s)", flush=True)
    total = time.perf_counter() - started
    machine = f"{platform.machine()}, {torch.get_num_threads()} torch thread(s), torch {torch.__version__}"
    lines = [
        f"Command: `.venv/bin/python benchmarks/claims.py --steps {args.steps} --readme` "
        f"(batch {args.batch_size}, {args.test_songs} test songs of {args.test_seconds:g} s; "
        f"{total / 60:.1f} min on {machine}, on a 2-core machine shared with other jobs).",
        "",
        *table(rows),
        "",
        *[f"- `{name}` not computed: {why}" for name, why in sorted(skipped.items())],
        "",
        *claims(rows, args.long_seconds),
    ]
    text = "\n".join(lines)
    print(text)
    if args.readme:
        write_section("claims", text)


if __name__ == "__main__":
    main()
