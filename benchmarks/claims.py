"""The claims benchmark: every model family under one fair protocol, and each paper's central claim as
its own experiment with a verdict.

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python benchmarks/claims.py [--quick] [--readme] [--only PART ...]

The protocol (``claims_protocol``): one data split by song of the multimodal ``synthetic-dance`` set
(songs 0-11 train, 3 dances each by different dancers; songs 12-15 test), mirroring, mel + onset +
librosa-beat features, root deltas + expmaps at 20 fps for every family; training to a validation
plateau within a step budget (best checkpoint kept); 5 training seeds × 5 samples per test song,
mean ± sd over seeds, differences between arms judged by bootstrap intervals against a rule stated
before the run; choices (the flow's temperature) made on selection songs, never the test songs; the
first 2 s (the rest-pose seed) cut from every dance before scoring. Parts:

- ``transflower`` (``claims_transflower``): flow vs regression head of one encoder, multimodal vs the
  homogeneous control, the flow at each temperature of the sweep;
- ``curriculum`` (``claims_curriculum``): DanceRevolution's schedules against teacher forcing over
  long songs, freezing and FID_k per minute;
- ``table``: the other families (MoGlow, the cross-breed) and TM2D's bundled model (music only: its
  own data, 30 fps and text stream, so its row says so).

Every run is cached as JSON under ``--cache``: a re-run skips what finished. ``--quick`` is the smoke
path (one seed, few steps, short songs; its own cache). ``--steps N [--seeds K]`` is a plateau study: the
same protocol with a budget of ``N`` steps, so the plateau rule rather than the budget ends each run (its
own cache; each result's ``best_step`` and ``stopped`` say which ended it); it sets every budget (the
Transflower experiment's and DanceRevolution's schedules' too) unless ``--tf-steps`` / ``--dr-steps`` set
those. ``--real-moves [FOLDER]`` runs the whole protocol on dances chained from real moves (the CMU dance
takes, less the held-out ones the bundled recipes leave out; ``Protocol.mocap``) in its own cache
(runs/claims-cache-real...), and ``--readme`` then writes the ``claims-real`` markers instead. The
Transflower experiment trains to ``Protocol.tf_steps`` (2000: at 1000, 4 of its 20 runs were still improving
at the budget), with its results in the cache folder named for that budget; the verdict lines say how many
runs the plateau rule ended. ``--readme`` writes the section
between the ``claims`` markers of benchmarks/README.md (the full run only), quoting TM2D's verdict lines
from their own sections (benchmarks/claims_tm2d.py: late fusion against slerp; claims_tm2d_music.py: the
music-only quality of the text-trained model). TM2D's fusion-weight experiment is benchmarks/text_spans.py.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time
from dataclasses import replace
from pathlib import Path

import claims_curriculum
import claims_protocol
import claims_transflower
import numpy as np
from claims_protocol import (
    CONTROL_TAKE,
    MOCAP_EXCLUDE,
    Protocol,
    TestSet,
    cached,
    generate,
    pm,
    reference_clips,
    score,
    scored,
)
from claims_runs import ground_truth, run_family
from readme_section import verdict_line, write_section

ROOT = Path(__file__).resolve().parents[1]
#: the real takes of ``--real-moves`` (read in place)
MOCAP = ROOT.parent / "shared" / "mocap" / "cmu-dance"
MOGLOW_SMALL = ["model.encoder.hidden=64", "model.encoder.layers=1", "model.encoder.dim=64", "model.head.steps=8",
                "model.head.coupling={dim: 64, layers: 1, heads: 4}"]
#: (key, row label, recipe, overrides)
OTHERS = [
    ("moglow", "MoGlow (moglow at small sizes)", "moglow", MOGLOW_SMALL),
    ("crossbreed", "Cross-breed (cross-breed-small: local attention + flow)", "cross-breed-small",
     ["data.segment_frames=60", "training.batch_size=16"]),
]
COLUMNS = [("FMD", "FMD ↓"), ("FID_k", "FID_k ↓"), ("Div_k", "Div_k"), ("Div_sample_pose", "sample div. (m)"),
           ("beat_locking", "beat lock ↑"), ("move_validity", "move valid ↑"), ("PFF", "PFF % ↓"),
           ("PFF_rel", "PFF_rel % ↓"), ("mpd_20", "MPD_20 (m) ↓"), ("mpd_speed", "its speed (m/s)")]


def row(label: str, runs: list[dict], note: str = "") -> str:
    """One table row: every column as mean ± sd over the runs (seeds), each at the temperature it chose on
    the selection songs (1 without a choice)."""
    cells = [pm([scored(r).get(k) for r in runs]) for k, _ in COLUMNS]
    nll = pm([r.get("nll") for r in runs])
    times = [r["train_s"] for r in runs if r.get("train_s") is not None]
    train = f"{np.mean(times):.0f} ± {np.std(times):.0f}" if times else "n/a"
    return f"| {label} | " + " | ".join(cells) + f" | {nll} | {train} | {len(runs)} | {note} |"


def gt_row(label: str, values: dict, note: str = "") -> str:
    """A row of real dances."""
    return f"| {label} | " + " | ".join(pm([values.get(k)]) for k, _ in COLUMNS) + f" | n/a | — | — | {note} |"


def tm2d_runs(protocol: Protocol, test: TestSet, reference) -> list[dict]:
    """The bundled tm2d-small (music only), sampled like every family: one run, no seeds to average."""
    from dance_core import get_registry
    from dance_core.api import load_recipe

    if "tm2d-small" not in get_registry().names("recipe"):
        return []

    def fresh() -> dict:
        recipe = load_recipe("tm2d-small", ["compose.threads=1"])
        ckpt = recipe.resolve_path(recipe.compose.checkpoint)
        clips, speed = generate(recipe, ckpt, test.songs, test.beats, protocol.samples)
        scores = score(clips, reference, protocol.metrics())
        return {"temperatures": {"1": {**scores, "frames_per_s": speed}}, "nll": None}

    saved, claims_protocol.CACHED_ONLY = claims_protocol.CACHED_ONLY, False  # no training: always composed
    try:
        return [cached(protocol, "tm2d-bundled", fresh)]
    finally:
        claims_protocol.CACHED_ONLY = saved


def run_table(protocol: Protocol, only, test: TestSet) -> dict:
    """Ground truth, shuffled music and the families outside the two experiments."""
    reference = reference_clips(protocol)
    out = {"gt": ground_truth(protocol, test, reference, "gt-multimodal")}
    songs = sorted({c.name.rsplit("-", 1)[0] for c in test.real})
    beats = {s: test.beats[songs[(i + 1) % len(songs)]] for i, s in enumerate(songs)}
    shuffled = [replace(c, music_beats=beats[c.name.rsplit("-", 1)[0]]) for c in test.real]
    out["shuffled"] = cached(protocol, "shuffled-multimodal", lambda: score(shuffled, reference, protocol.metrics()))
    out["tm2d"] = tm2d_runs(protocol, test, reference)
    for key, _, recipe, extra in OTHERS:
        if not only or "table" in only:
            runs = [run_family(protocol, key, recipe, extra, s, test, reference) for s in range(protocol.seeds)]
            out[key] = [r for r in runs if r]
            print(f"done: {key}", flush=True)
    return out


def claims_table(table: dict, tf: dict | None, cur: dict | None, protocol: Protocol) -> list[str]:
    """The markdown table of every family on the multimodal test songs."""
    head = ["model", *[c for _, c in COLUMNS], "NLL (nats/frame)", "train (s)", "seeds", "note"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head),
             gt_row("Real dances (test songs, 3 " + ("real-moves dances" if protocol.mocap else "dancers") + " each)",
                    table["gt"]),
             gt_row("Shuffled music (real dances, another song's beats)", table["shuffled"])]
    if tf and tf["multimodal"]["flow"] and tf["multimodal"]["regression"]:
        mm = tf["multimodal"]
        note = (f"T per seed {claims_transflower.chosen(mm['flow'])} (chosen on the selection songs); budget "
                f"{protocol.tf_steps} steps, the other rows' {protocol.steps}")
        lines.append(row("Transflower (transflower-small, flow head)", mm["flow"], note))
        lines.append(row("AI Choreographer (transflower-small's encoder, regression head)", mm["regression"],
                         note=f"budget {protocol.tf_steps} steps"))
    for key, label, _, _ in OTHERS:
        if table.get(key):
            lines.append(row(label, table[key]))
    if cur and cur.get("linear"):
        lines.append(row("DanceRevolution (dancerevolution-small, linear curriculum)", cur["linear"],
                         note="6.4-s segments (128 frames), q → 30"))
    if cur and cur.get("teacher forcing"):
        lines.append(row("DanceRevolution, pure teacher forcing", cur["teacher forcing"]))
    if table.get("tm2d"):
        tm2d_name = "TM2D (tm2d-small, the bundled weights, music only)"
        lines.append(row(tm2d_name, table["tm2d"],
                         note="not the common protocol: its own training set (dances chained from real CMU moves and "
                              "the text-labelled synthetic moves; its model card), 30 fps resampled to 20, its "
                              "features; one training run, 5 samples"))
    return lines


def main() -> None:
    """Run the parts asked for, print the tables and verdicts, optionally write them into the README."""
    import torch

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the smoke path: one seed, few steps, short songs")
    parser.add_argument("--reduced", action="store_true",
                        help="3 seeds, 40 steps, short songs: about ten minutes per experiment on one thread; its "
                             "verdicts are marked reduced and never written into the README")
    parser.add_argument("--cache", default=None, help="result cache (default runs/claims-cache[-quick])")
    parser.add_argument("--only", nargs="*", choices=["transflower", "curriculum", "table"], default=None)
    parser.add_argument("--cached-only", action="store_true",
                        help="report the cached runs, train nothing new (the TM2D row, which trains nothing, is "
                             "still composed)")
    parser.add_argument("--steps", type=int, default=None,
                        help="a plateau study: this step budget (validation every 25 steps, the same patience) in its "
                             "own cache, runs/claims-cache-steps<N>; never written into the README")
    parser.add_argument("--seeds", type=int, default=None, help="with --steps: seeds per arm (default 5)")
    parser.add_argument("--tf-steps", type=int, default=None,
                        help="the Transflower experiment's budget (default: --steps when given, else 2000)")
    parser.add_argument("--dr-steps", type=int, default=None,
                        help="DanceRevolution's schedules' budget (default: --steps when given, else 120)")
    parser.add_argument("--real-moves", nargs="?", const=str(MOCAP), default=None, metavar="FOLDER",
                        help="every dance chained from the real moves of these takes (default ../shared/mocap/"
                             "cmu-dance) less the held-out ones; its own cache, runs/claims-cache-real...")
    parser.add_argument("--readme", action="store_true", help="write the result into benchmarks/README.md")
    args = parser.parse_args()
    mocap = None if args.real_moves is None else Path(args.real_moves).resolve()
    if mocap is not None and not mocap.is_dir():
        parser.error(f"--real-moves: no folder of takes at {mocap} (the CMU dance takes, ../shared/mocap/cmu-dance)")
    torch.set_num_threads(1)
    tag = "-quick" if args.quick else "-reduced" if args.reduced else f"-steps{args.steps}" if args.steps else ""
    tag += (f"-tf{args.tf_steps}" if args.tf_steps else "") + (f"-dr{args.dr_steps}" if args.dr_steps else "")
    cache = Path(args.cache or ROOT / "runs" / f"claims-cache{'-real' if mocap else ''}{tag}")
    protocol = (Protocol.quick(cache) if args.quick else Protocol.reduced(cache) if args.reduced
                else Protocol(cache=cache))
    if args.steps or args.seeds:
        protocol = dataclasses.replace(protocol, steps=args.steps or protocol.steps, dr_steps=args.steps or
                                       protocol.dr_steps, tf_steps=args.steps or protocol.tf_steps,
                                       seeds=args.seeds or protocol.seeds)
    protocol = dataclasses.replace(protocol, tf_steps=args.tf_steps or protocol.tf_steps,
                                   dr_steps=args.dr_steps or protocol.dr_steps, mocap=mocap)
    # the Transflower experiment trains to its own budget (the plateau within reach), in its own cache
    tf_protocol = protocol if protocol.tf_steps == protocol.steps else dataclasses.replace(
        protocol, steps=protocol.tf_steps, cache=cache.with_name(f"{cache.name}-steps{protocol.tf_steps}"))
    study = args.steps or args.seeds or args.tf_steps or args.dr_steps
    reduced = (" (reduced run: --reduced)" if args.reduced else " (smoke run: --quick)" if args.quick else
               f" (plateau study: --steps {protocol.steps}, {protocol.seeds} seeds)" if study else "")
    started = time.perf_counter()
    want = set(args.only or ["transflower", "curriculum", "table"])
    claims_protocol.CACHED_ONLY = args.cached_only
    short = TestSet(protocol, protocol.test_seconds, protocol.test_songs)
    tf = claims_transflower.run(tf_protocol) if "transflower" in want else None
    cur = claims_curriculum.run(protocol, short) if "curriculum" in want else None
    table = run_table(protocol, args.only, short)
    total = time.perf_counter() - started
    load = os.getloadavg()[0]
    files = sorted((protocol.cache / "results").glob("*.json"), key=lambda p: p.stat().st_mtime)
    span = (files[-1].stat().st_mtime - files[0].stat().st_mtime) / 60 if files else 0.0
    lines = [
        f"Command: `OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python benchmarks/claims.py{' --quick' * args.quick}"
        f"{' --reduced' * args.reduced}"
        f"{' --cached-only' * args.cached_only}{' --only ' + ' '.join(args.only) if args.only else ''}"
        f"{f' --steps {args.steps}' if args.steps else ''}{f' --seeds {args.seeds}' if args.seeds else ''}"
        f"{f' --tf-steps {args.tf_steps}' if args.tf_steps else ''}"
        f"{f' --dr-steps {args.dr_steps}' if args.dr_steps else ''}{' --real-moves' * bool(mocap)}"
        f"{f' --cache {args.cache}' if args.cache else ''}"
        f"{' --readme' * args.readme}`; {len(files)} cached results written over {span:.0f} "
        f"min of wall time, this invocation "
        f"{total / 60:.1f} min, on {platform.machine()}, "
        f"{os.cpu_count()} cores shared with other engineers' jobs, load average {load:.1f} at the end, 1 torch "
        f"thread, torch {torch.__version__}. Protocol: {protocol.seeds} seeds × {protocol.samples} samples per "
        f"test song, {protocol.test_songs} test songs of {protocol.test_seconds:g} s, budget {protocol.steps} "
        f"steps (the Transflower experiment {tf_protocol.steps}, its results in {tf_protocol.cache.name}; "
        f"DanceRevolution's schedules {protocol.dr_steps}; validation every {protocol.val_every}, patience "
        f"{protocol.patience}), batch {protocol.batch_size}."
        + (f" Real moves: every dance (training, selection, test, reference) chained from the takes in {mocap.name} "
           f"less {', '.join(MOCAP_EXCLUDE)} (held out by the bundled recipes: one pool of takes for every split); "
           f"the control one take ({CONTROL_TAKE}), one walk for every song and dance; move validity n/a (no "
           f"move labels)." if mocap else ""),
        "",
        *claims_table(table, tf, cur, protocol),
        "",
    ]
    if tf:
        lines += [f"Transflower experiment (flow vs regression head, same encoder; budget {tf_protocol.steps} steps):",
                  "", *claims_transflower.table(tf, tf_protocol), ""]
    if cur:
        lines += [f"DanceRevolution experiment ({protocol.long_songs} held-out songs of {protocol.long_seconds:g} s):",
                  "", *claims_curriculum.table(cur), ""]
    if tf:
        lines.append(claims_transflower.verdict(tf, tf_protocol, reduced))
    if cur:
        lines.append(claims_curriculum.verdict(cur, protocol, reduced))
    tm2d = verdict_line("- **TM2D** (late fusion")  # claims_tm2d.py's verdict; its section has the tables
    music = verdict_line("- **TM2D, music-only quality**")  # claims_tm2d_music.py's verdict (its own section)
    if not mocap:  # TM2D's claims are tested on their own data, not on this protocol's: quoted once, above
        lines.append(tm2d if tm2d else "- **TM2D**: not run yet: benchmarks/claims_tm2d.py tests its claim (late "
                     "fusion against the slerp baseline at the span edges).")
        if music:
            lines.append(music)
    text = "\n".join(lines)
    print(text)
    if args.readme and mocap and not (args.quick or args.reduced):  # real moves: their own block
        write_section("claims-real", text)
    elif args.readme and not (args.quick or args.reduced or study):  # only the full run writes the README's figures
        write_section("claims", text)


if __name__ == "__main__":
    main()
