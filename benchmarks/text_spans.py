"""TM2D text spans on real songs: does a prompted move appear inside its span, and not outside?

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/text_spans.py [RECIPE] [--checkpoint PATH]
        [--music SONG ...] [--moves jump clap ...] [--fusion 0 0.4 0.8 1.0] [--samples 3]
        [--validate N] [--set FIELD=VALUE ...] [--json OUT] [--readme]

For every song (default: the fixture songs ``../shared/fixtures/audio/*.ogg``, which no model here
trained on), the recipe's model (default ``tm2d-small`` with its bundled weights) composes
``--samples`` dances music-only and, for every move and every peak fusion weight
(``model.head.fusion``), with one text span over the middle third of the song, with the same seed
(so the samples of both start from the same noise). Every dance goes the way ``dance compose`` writes
it (denormalized, decoded to the skeleton, grounded) and through forward kinematics to joint positions.

The move detectors of ``dance_core.evaluation.move_detect`` (kinematic rules on joint positions; they
import nothing of the synthetic dancer nor of any model) then say, per whole second, whether the
prompted move is seen. Per move and fusion weight the table gives the share of seconds with the move:
inside the span with the text, inside the same span in the music-only dance, and before / after the
span with the text; mean ± standard deviation over songs × samples. ``--validate N`` first scores the
detectors against the synthetic dancer's own text labels (N dances of 40 s, seeds the detectors'
thresholds were not tuned on): precision and recall per second.

Verdict (TM2D's claim: text late fusion makes the prompted move appear inside its span and not outside,
against music-only generation with the same noise): at the recipe's fusion weight (0.8) a move is
*steered* when its share inside the span with the text exceeds both the music-only share in the same
span and the share after the span by at least ``MARGIN``; the claim holds when most moves are steered,
does not hold when at most one is, and is inconclusive otherwise. ``--readme`` writes the section
between the ``text-spans`` markers of benchmarks/README.md.
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
from readme_section import write_section

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_MUSIC = ROOT.parent / "shared" / "fixtures" / "audio"
#: the prompt per move: the synthetic dancer's label wording of it (one of the phrasings tm2d-small trained on)
PROMPTS = {
    "jump": "a person jumps on the beat",
    "clap": "a person claps on the beat",
    "spin": "a person spins around",
    "kick": "a person kicks their legs forward",
    "arm-wave": "a person waves their arms overhead",
}
MARGIN = 0.2  # share of seconds
PAPER_FUSION = 0.8


def load(recipe: str, checkpoint: str | None, fusion: float | None, samples: int, extra: list[str] = ()):
    """The recipe (with ``model.head.fusion``, ``compose.samples`` and ``extra`` overrides set) with its model
    loaded (a ``Composer``: recipe, model, checkpoint, features)."""
    from dance_core.api import Composer, load_recipe

    sets = [*extra, f"compose.samples={samples}"] + ([f"model.head.fusion={fusion}"] if fusion is not None else [])
    return Composer(load_recipe(recipe, sets), checkpoint, device="cpu")


def song_streams(path: Path, stack, ckpt) -> tuple[dict[str, np.ndarray], int, object]:
    """The song's standardized streams without text (computed once per song), frame count and audio."""
    from dance_core import get_registry, load_audio

    audio = load_audio(str(path), get_registry())
    n = audio.n_frames(stack.fps)
    raw = stack.extract(n, audio, ())
    return {k: ckpt.stats.streams[k].apply(v) for k, v in raw.items()}, n, audio


def with_text(streams: dict[str, np.ndarray], stack, ckpt, n: int, text: str, start: float, end: float):
    """The streams with the text stream(s) recomputed for one span, and the span's table (what the head
    reads: the span in force per frame, the text streams' rows), standardized."""
    from dance_core import FeatureInputs, TextSpan, get_registry

    reg = get_registry()
    spans = (TextSpan(text, start, end),)
    inputs = FeatureInputs(n_frames=n, audio=None, texts=spans)
    out = dict(streams)
    for name, extractors in stack.streams.items():
        if any("text" in reg.get("feature", p).info.get("reads", ("audio",)) for p, _ in extractors):
            values = np.concatenate([np.asarray(x.extract(inputs, stack.fps), np.float32) for _, x in extractors], 1)
            out[name] = ckpt.stats.streams[name].apply(values)
    return out, stack.span_table(n, spans).map_features(ckpt.stats.apply_rows)


def dances(composer, streams, n: int, name: str, spans=None) -> list[np.ndarray]:
    """``compose.samples`` dances as joint positions ``(T, 24, 3)``, as ``dance compose`` writes them
    (``spans``: the song's span table, None for music only)."""
    from dance_core.api import Song

    song = Song(name, streams, n, spans=spans)
    motion = composer.generate(song, composer.seed("rest"))
    return [np.asarray(data.skeleton_motion.positions(), np.float64) for data in composer.dances(song, motion)]


def shares(move: str, positions: np.ndarray, fps: float, start: float, end: float) -> dict[str, float]:
    """Share of seconds with the move before, inside and after ``[start, end)``."""
    from dance_core.evaluation import detect, move_share

    hit = detect(move, positions, fps)
    return {"before": move_share(hit, fps, 0.0, start), "inside": move_share(hit, fps, start, end),
            "after": move_share(hit, fps, end, None)}


def validate(n: int, first: int = 100) -> dict[str, dict[str, float]]:
    """Per-second precision and recall of each detector against the synthetic dancer's move labels
    (classic dancer, 40 s dances ``first``..``first+n-1`` of seed 0, 30 fps). Recall: of the seconds the
    move covers at least half of, those where the detector fires; precision: of the seconds where it
    fires, those the move covers at least a tenth of (moves change within a second, blended)."""
    from dance_core.evaluation import DETECTORS, detect, second_hits
    from dance_core.synth import PHRASINGS, make_clip

    label_of = {t: m for m, ts in PHRASINGS.items() for t in ts}
    counts = {m: [0, 0, 0, 0] for m in DETECTORS}  # hits on the move, hits, seconds of the move, found
    for i in range(first, first + n):
        clip = make_clip(i, seed=0, seconds=40.0, bpm=(70.0, 180.0), rate=8000, fps=30.0)
        pos = clip.motion.skeleton_motion.positions()
        secs = int(len(pos) // 30)
        cover = {m: np.zeros(secs) for m in DETECTORS}
        for span in clip.texts:
            move = label_of[span.text]
            if move in cover:
                for s in range(secs):
                    cover[move][s] += max(0.0, min(s + 1, span.end) - max(s, span.start))
        for m in DETECTORS:
            hits = second_hits(detect(m, pos, 30.0), 30.0)[:secs]
            c, cov = counts[m], cover[m][: len(hits)]
            c[0] += int((hits & (cov >= 0.1)).sum())
            c[1] += int(hits.sum())
            c[2] += int((cov >= 0.5).sum())
            c[3] += int((hits & (cov >= 0.5)).sum())
    return {m: {"precision": a / max(1, b), "recall": d / max(1, c), "labelled": c}
            for m, (a, b, c, d) in counts.items()}


def ms(values: list[float]) -> str:
    """Mean ± standard deviation."""
    v = np.asarray([x for x in values if np.isfinite(x)])
    return "—" if not len(v) else f"{v.mean():.2f} ± {v.std():.2f}"


def verdict(results: dict, moves: list[str], fusion: float) -> tuple[str, list[str]]:
    """holds / does not hold / inconclusive, and the moves steered at ``fusion``."""
    steered = []
    for m in moves:
        r = results["text"][m][str(fusion)]
        inside = np.mean(r["inside"])
        if inside - np.mean(results["music"][m]["inside"]) >= MARGIN and inside - np.mean(r["after"]) >= MARGIN:
            steered.append(m)
    if len(steered) > len(moves) / 2:
        return "holds", steered
    return ("does not hold" if len(steered) <= 1 else "inconclusive"), steered


def report(results: dict, args, moves: list[str], fusions: list[float], songs: list[Path], val, wall: float) -> str:
    """The README section."""
    load = f", load average {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    import torch

    cmd = "OMP_NUM_THREADS=1 .venv/bin/python benchmarks/text_spans.py " + shlex.join(sys.argv[1:])
    lines = [f"Command: `{cmd}`; {args.date}; {platform.machine()}, {os.cpu_count()} cores{load}, 1 torch thread, "
             f"torch {torch.__version__}; {wall / 60:.1f} min. Model: `{args.recipe}`"
             f" ({args.checkpoint or 'its bundled weights'}); songs: {', '.join(s.stem for s in songs)}; "
             f"{args.samples} samples per song (one seed, a batch), span = the middle third of each song; "
             "shares of whole seconds in which the detector sees the move, mean ± std over songs × samples.", ""]
    if val:
        lines += ["Detectors against the synthetic dancer's labels (per second; dances 100-"
                  f"{99 + args.validate} of seed 0, 40 s each; thresholds were set on dances 0-11):", "",
                  "| move | precision | recall | labelled seconds |", "|---|---|---|---|"]
        lines += [f"| {m} | {v['precision']:.2f} | {v['recall']:.2f} | {v['labelled']} |" for m, v in val.items()]
        lines.append("")
    lines += ["| move | fusion | inside, text | inside, music only | before, text | after, text |",
              "|---|---|---|---|---|---|"]
    for m in moves:
        music = results["music"][m]
        for f in fusions:
            r = results["text"][m][str(f)]
            lines.append(f"| {m} | {f:g} | **{ms(r['inside'])}** | {ms(music['inside'])} | {ms(r['before'])} | "
                         f"{ms(r['after'])} |")
    word, steered = verdict(results, moves, PAPER_FUSION if PAPER_FUSION in fusions else fusions[-1])
    same = results.get("fusion0_equals_music")
    if same:
        lines += ["", f"Fusion 0 (the text branch never runs) gave the music-only dances bit for bit on "
                  f"{sum(same)}/{len(same)} songs (checked with the first move; the other moves' fusion-0 rows "
                  "reuse the music-only dances)."]
    lines += ["", f"Moves steered at fusion {PAPER_FUSION:g} (inside with text ≥ {MARGIN} above both music-only "
              f"inside and after the span): {', '.join(steered) or 'none'} ({len(steered)}/{len(moves)})."]
    return "\n".join(lines) + "\n", word, steered


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("recipe", nargs="?", default="tm2d-small")
    p.add_argument("--checkpoint")
    p.add_argument("--music", nargs="+", type=Path)
    p.add_argument("--moves", nargs="+", default=list(PROMPTS))
    p.add_argument("--fusion", nargs="+", type=float, default=[0.0, 0.4, 0.8, 1.0])
    p.add_argument("--samples", type=int, default=3)
    p.add_argument("--validate", type=int, default=30, help="synthetic dances to validate the detectors on (0: skip)")
    p.add_argument("--set", dest="sets", action="append", default=[], help="recipe override (repeatable)")
    p.add_argument("--json", type=Path, help="write every share here")
    p.add_argument("--date", default=datetime.date.today().isoformat())
    p.add_argument("--readme", action="store_true")
    args = p.parse_args(argv)
    songs = args.music or sorted(DEFAULT_MUSIC.glob("*.ogg"))
    unknown = [m for m in args.moves if m not in PROMPTS]
    if unknown:
        p.error(f"--moves: no prompt for {', '.join(unknown)} (have: {', '.join(PROMPTS)})")
    start_time = time.perf_counter()
    val = validate(args.validate) if args.validate else None
    if val:
        for m, v in val.items():
            print(f"detector {m}: precision {v['precision']:.2f} recall {v['recall']:.2f}", flush=True)
    empty = lambda: {"before": [], "inside": [], "after": []}  # noqa: E731
    results = {"music": {m: empty() for m in args.moves},
               "text": {m: {str(f): empty() for f in args.fusion} for m in args.moves}}
    music_only = load(args.recipe, args.checkpoint, None, args.samples, args.sets)
    stack, ckpt = music_only.stack, music_only.checkpoint
    models = {f: load(args.recipe, args.checkpoint, f, args.samples, args.sets) for f in args.fusion}
    for song in songs:
        streams, n, _ = song_streams(song, stack, ckpt)
        seconds = n / stack.fps
        start, end = round(seconds / 3, 2), round(2 * seconds / 3, 2)
        plain = dances(music_only, streams, n, song.stem)
        for m in args.moves:
            for pos in plain:
                for k, v in shares(m, pos, stack.fps, start, end).items():
                    results["music"][m][k].append(v)
        for m in args.moves:
            text_streams, spans = with_text(streams, stack, ckpt, n, PROMPTS[m], start, end)
            for f in args.fusion:
                # fusion 0 is checked below on the first move: the music-only dance
                reuse = f == 0 and m != args.moves[0]
                steered = plain if reuse else dances(models[f], text_streams, n, song.stem, spans)
                if f == 0 and m == args.moves[0]:  # no text weight anywhere: the music-only dance itself
                    same = all(np.array_equal(a, b) for a, b in zip(plain, steered, strict=True))
                    results.setdefault("fusion0_equals_music", []).append(bool(same))
                for pos in steered:
                    for k, v in shares(m, pos, stack.fps, start, end).items():
                        results["text"][m][str(f)][k].append(v)
                got = np.mean(results["text"][m][str(f)]["inside"][-args.samples:])
                base = np.mean(results["music"][m]["inside"][-args.samples:])
                print(f"{song.stem} {m} fusion {f:g}: inside {got:.2f} (music only {base:.2f})", flush=True)
    wall = time.perf_counter() - start_time
    text, word, steered = report(results, args, args.moves, args.fusion, songs, val, wall)
    print(text)
    print(f"TM2D verdict: {word} ({', '.join(steered) or 'no move'} steered)")
    if args.json:
        args.json.write_text(json.dumps({"results": results, "validation": val}, indent=1), encoding="utf-8")
    if args.readme:
        write_section("text-spans", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
