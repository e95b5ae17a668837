"""DanceRevolution's claim as its own experiment: curriculum (dynamic auto-condition) training keeps an
LSTM dancing over long songs where pure teacher forcing freezes or drifts.

dancerevolution-small under the common protocol, trained on 8-s segments (160 frames, p = 10
ground-truth inputs per period) with q from each schedule: teacher forcing (q = 0), const (q = 10),
linear, quadratic and exponential, their rates set so that q reaches 30 in the last of ten "epochs"
(an epoch here is a tenth of the step budget: the data's true epoch is longer than the budget, and the
schedules grow with the epoch). Validation is teacher-forced for every schedule, so the plateau rule
compares like with like. Each model composes ``long_songs`` held-out songs of ``long_seconds`` s
(5 samples each); freezing (PFF, PFF_rel, AUC_f) and FID_k are measured per minute over time, FID_k
on the 10-s windows of that minute against the 10-s windows of the training dances.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from claims_protocol import (
    MEMO,
    Protocol,
    TestSet,
    cached,
    ci,
    decide,
    difference,
    generate,
    plateau_ends,
    reference_clips,
    spread,
    train_to_plateau,
)

EPOCHS = 10
Q_END = 30
SEGMENT = 128


def schedules() -> list[tuple[str, str]]:
    """(label, schedule override) for teacher forcing and the four growth functions."""
    s = "training.schedules.auto_condition="
    return [
        ("teacher forcing", s + "{plugin: constant, value: 0}"),
        ("const (q=10)", s + "{plugin: auto-condition-const, value: 10}"),
        ("linear", s + f"{{plugin: auto-condition-linear, rate: {Q_END / EPOCHS:g}, offset: 1}}"),
        ("quadratic", s + f"{{plugin: auto-condition-quadratic, rate: {Q_END / EPOCHS**2:g}, offset: 1}}"),
        ("exponential", s + f"{{plugin: auto-condition-exponential, rate: {Q_END / math.exp(EPOCHS):.6g}, "
                            f"offset: 1, limit: {Q_END}}}"),
    ]


def windows(clips, seconds: float = 10.0):
    """Consecutive ``seconds``-long pieces of each clip, as clips named ``CLIP@k``."""
    out = []
    for c in clips:
        n = int(round(seconds * c.fps))
        for k in range(len(c.positions) // n):
            out.append(replace(c, name=f"{c.name}@{k}", positions=np.asarray(c.positions)[k * n:(k + 1) * n],
                               music_beats=None))
    return out


def over_time(clips, reference, minute: float = 60.0) -> list[dict]:
    """Per minute of the dances: PFF, PFF_rel, AUC_f (over that minute of every dance) and FID_k (its
    10-s windows against the reference's 10-s windows)."""
    from dance_core.api import EvaluateOptions, evaluate

    ref_windows = windows(reference)
    length = min(len(c.positions) for c in clips) / clips[0].fps
    out = []
    for m in range(max(1, int(length // minute))):
        a, b = int(m * minute * clips[0].fps), int((m + 1) * minute * clips[0].fps)
        part = [replace(c, positions=np.asarray(c.positions)[a:b], music_beats=None) for c in clips]
        v = evaluate(part, reference, EvaluateOptions(metrics=["freezing"])).values()
        v.update(evaluate(windows(part), ref_windows, EvaluateOptions(metrics=["fid-k"])).values())
        out.append({k: (None if v.get(k) is None else float(v[k])) for k in ("PFF", "PFF_rel", "AUC_f", "FID_k")})
    return out


def long_songs(protocol: Protocol) -> TestSet:
    """The held-out long songs: ``long_songs`` different songs (12, 13, ...), each with its first real dance."""
    return TestSet(protocol, protocol.long_seconds, protocol.long_songs, tag="long", dances=1)


def run(protocol: Protocol, short: TestSet | None = None) -> dict:
    """Every (schedule, seed) run: ``{label: [runs]}``, each with per-minute values on the long songs (and,
    with ``short``, the claims table's metrics on those test songs: the DanceRevolution row)."""
    from claims_protocol import score

    from dance_core.api import load_recipe

    test = long_songs(protocol)
    reference = reference_clips(protocol)
    protocol = replace(protocol, steps=protocol.dr_steps)
    epoch = max(1, protocol.steps // EPOCHS)
    extra = [f"data.segment_frames={SEGMENT}", "training.batch_size=16", "model.head.teacher_frames=10"]
    out = {}
    for label, schedule in schedules():
        runs = []
        for seed in range(protocol.seeds):
            key = f"dr-{label.split()[0]}-s{seed}"

            def fresh(schedule=schedule, seed=seed, key=key, label=label) -> dict:
                MEMO.install()
                recipe = load_recipe("dancerevolution-small", [*protocol.common(), *extra, schedule, f"seed={seed}"])
                r = train_to_plateau(recipe, protocol.cache / "work" / key, protocol, epoch_steps=epoch,
                                     val_values={"auto_condition": 0.0})
                clips, speed = generate(recipe, r["checkpoint"], test.songs, test.beats, protocol.samples)
                out = {**r, "frames_per_s": speed, "minutes": over_time(clips, reference)}
                if short is not None and label in ("teacher forcing", "linear"):  # the table's two rows
                    clips, speed = generate(recipe, r["checkpoint"], short.songs, short.beats, protocol.samples)
                    out["temperatures"] = {"1": {**score(clips, reference, protocol.metrics()), "frames_per_s": speed}}
                    out["nll"] = None
                return out

            runs.append(cached(protocol, key, fresh))
        out[label] = [r for r in runs if r]
        print(f"done: curriculum {label}", flush=True)
    return out


def _per_minute(runs: list[dict], key: str, m: int) -> list:
    return [r["minutes"][m][key] if m < len(r["minutes"]) else None for r in runs]


def table(result: dict) -> list[str]:
    """Per schedule: best step, and PFF_rel / AUC_f / FID_k in the first and the last minute."""
    from claims_protocol import pm

    lines = ["| schedule | best step | PFF % (all) | PFF_rel % first → last minute | AUC_f first → last | "
             "FID_k first → last minute |", "|---|---|---|---|---|---|"]
    for label, runs in result.items():
        if not runs:
            lines.append(f"| {label} | not run | | | | |")
            continue
        last = max(len(r["minutes"]) for r in runs) - 1
        pff = pm([np.mean([m["PFF"] for m in r["minutes"]]) for r in runs])
        cells = [f"{pm(_per_minute(runs, k, 0))} → {pm(_per_minute(runs, k, last))}"
                 for k in ("PFF_rel", "AUC_f", "FID_k")]
        lines.append(f"| {label} | {pm([r['best_step'] for r in runs])} | {pff} | " + " | ".join(cells) + " |")
    return lines


RULE = ("for each schedule, the 95 % bootstrap intervals over seeds of PFF_rel(teacher forcing) − PFF_rel(schedule) "
        "over the whole long songs and of FID_k(teacher forcing) − FID_k(schedule) in their last minute; holds when "
        "both lie above 0 for every schedule, does not hold when no schedule is better on both and one is worse "
        "on either (an interval wholly below 0); inconclusive otherwise, and when no model froze at all (the "
        "freezing half of the claim has nothing to measure)")


def verdict(result: dict, protocol: Protocol, reduced: str = "") -> str:
    """The DanceRevolution verdict line (freezing over the whole long songs; FID_k in the last minute), with
    bootstrap intervals of each schedule's differences from teacher forcing and the rule."""

    def whole(runs, key):
        return [np.mean([m[key] for m in r["minutes"] if m[key] is not None] or [np.nan]) for r in runs]

    if not result or not all(result.values()):
        return "- **DanceRevolution**: inconclusive — not every schedule's runs finished within the budget."
    tf = result["teacher forcing"]
    last = max(len(r["minutes"]) for r in tf) - 1
    parts, better, worse = [], 0, 0
    for label, runs in result.items():
        if label == "teacher forcing":
            continue
        rel = difference(whole(tf, "PFF_rel"), whole(runs, "PFF_rel"))
        fid = difference(_per_minute(tf, "FID_k", last), _per_minute(runs, "FID_k", last))
        readings = (decide(rel), decide(fid))
        better += int(readings == ("above", "above"))
        worse += int("below" in readings)
        parts.append(f"{label}: PFF_rel gain {ci(rel)} %, last-minute FID_k gain {ci(fid)}")
    seeds = min(len(r) for r in result.values())
    tf_rel, tf_fid = spread(whole(tf, "PFF_rel"))[0], spread(_per_minute(tf, "FID_k", last))[0]
    numbers = (f"over {protocol.long_seconds / 60:.3g}-min songs, teacher forcing PFF_rel {tf_rel:.3g} %, "
               f"last-minute FID_k {tf_fid:.3g}; "
               "gains over teacher forcing (positive: the schedule is better) " + "; ".join(parts)
               + f" ({seeds} seeds × {protocol.samples} samples; "
               + plateau_ends([r for runs in result.values() for r in runs], protocol.dr_steps) + ")")
    frozen = any(v and v > 0 for runs in result.values() for v in whole(runs, "PFF_rel"))
    if not frozen:
        word = "inconclusive (no model froze under any schedule, so curriculum has nothing to prevent here)"
    elif better == len(parts):
        word = "holds"
    elif better == 0 and worse:
        word = "does not hold"
    else:
        word = f"inconclusive ({better} of {len(parts)} schedules better on both)"
    return ("- **DanceRevolution** (curriculum training freezes less and stays closer to real dancing over long "
            f"songs than pure teacher forcing): {numbers}: **{word}**{reduced}. Rule: {RULE}.")
