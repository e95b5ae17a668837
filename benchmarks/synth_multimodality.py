"""How multimodal is the synthetic choreography? A train-free estimate on three sets of the same songs.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/synth_multimodality.py [--songs 16] [--dances 6]

Sets (``synthetic-dance`` options): the classic dancer alone (the default, the dances of before the
dancer profiles), every dancer (``dancers: null``, a different dancer per dance of a song) and the
homogeneous control (``homogeneous: true``: one dancer, one style, one fixed routine).

- **Nearest neighbour**: for windows every second of every dance, the past 2 s of joint positions (at
  10 fps, in the body frame of the present frame, ``evaluation.canon``) is matched to the nearest past
  among the other songs' dances (every 0.2 s); that neighbour's next 0.5 s predicts the dance's next
  0.5 s. Reported: the RMS joint distance of the matched pasts and of the predicted futures (m), their
  ratio, the spread (mean pairwise RMS distance) of the futures of the 8 nearest pasts, and how many
  distinct moves those 8 neighbours dance 0.5 s after their present (the move labels).
- **Labels**: at every beat, the context is the dancer, the beat's place in the bar and the moves at
  the beats of the last 2 s; the outcome is the move 0.5 s later. Over contexts seen at least 5 times:
  the mean number of distinct outcomes after one context, the chance that two outcomes of one context
  differ (unbiased, so not lowered by rare contexts) and the conditional entropy H(outcome | context)
  in bits (all weighted by how often a context occurs).
- **Move validity** (the ``move-validity`` metric, with the songs' beats) of the dances and of the
  same dances played backwards.

Prints markdown tables for benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections import Counter, defaultdict

import numpy as np

from dance_core import JointClip
from dance_core.evaluation import SMPL_HIPS, MoveValidity, canonicalize
from dance_core.synth import make_clip

FPS, STEP = 30.0, 3  # generated at 30 fps, compared at 10 fps
PAST, FUTURE = 20, 5  # 2 s and 0.5 s at 10 fps
SETS = {
    "classic dancer (default)": {},
    "all dancers (`dancers: null`)": {"dancers": None},
    "homogeneous control (`homogeneous: true`)": {"homogeneous": True},
}


def windows(clip, stride: int) -> tuple[np.ndarray, list[str]]:
    """Windows of ``PAST + FUTURE`` frames every ``stride`` frames, each in the body frame of its present
    frame (the last past frame), ``(N, PAST + FUTURE, J, 3)``, and the move 0.5 s after each present."""
    positions = clip.motion.skeleton_motion.positions()[::STEP]
    starts = np.arange(0, len(positions) - PAST - FUTURE + 1, stride)
    w = np.stack([positions[s : s + PAST + FUTURE] for s in starts])
    fps = FPS / STEP
    return canonicalize(w, PAST - 1, *SMPL_HIPS), [move_at(clip, (s + PAST - 1) / fps + 0.5) for s in starts]


def nearest_neighbour(clips: list, songs: list[int]) -> dict[str, float]:
    """Leave-one-song-out nearest-neighbour prediction of the next 0.5 s from the past 2 s."""
    base, labels = zip(*(windows(c, 2) for c in clips), strict=True)
    query = [windows(c, 10)[0] for c in clips]
    db = np.concatenate(base).astype(np.float32)
    db_label = np.asarray([m for ms in labels for m in ms])
    db_song = np.concatenate([[s] * len(b) for s, b in zip(songs, base, strict=True)])
    joints = db.shape[2]
    db_past = db[:, :PAST].reshape(len(db), -1)
    db_future = db[:, PAST:].reshape(len(db), -1)
    sq = (db_past**2).sum(1)
    past_d, future_d, spread, distinct = [], [], [], []
    for s, q in zip(songs, query, strict=True):
        qp = q[:, :PAST].reshape(len(q), -1).astype(np.float32)
        qf = q[:, PAST:].reshape(len(q), -1).astype(np.float32)
        d = sq[None] - 2 * qp @ db_past.T + (qp**2).sum(1)[:, None]
        d[:, db_song == s] = np.inf
        near = np.argsort(d, axis=1)[:, :8]
        past_d += list(np.sqrt(np.maximum(d[np.arange(len(q)), near[:, 0]], 0) / (PAST * joints)))
        future_d += list(np.sqrt(((db_future[near[:, 0]] - qf) ** 2).sum(1) / (FUTURE * joints)))
        for row in near:
            distinct.append(len(set(db_label[row])))
            f = db_future[row]
            pair = ((f[:, None] - f[None]) ** 2).sum(-1) / (FUTURE * joints)
            spread.append(np.sqrt(pair[np.triu_indices(len(row), 1)]).mean())
    past, future = float(np.mean(past_d)), float(np.mean(future_d))
    return {"past": past, "future": future, "ratio": future / past, "spread": float(np.mean(spread)),
            "distinct": float(np.mean(distinct))}


def move_at(clip, t: float) -> str:
    """The move label of ``clip`` at time ``t`` (its text span)."""
    for span in clip.texts:
        if span.start <= t < span.end:
            return span.text
    return clip.texts[-1].text


def label_contexts(clips: list) -> dict[str, float]:
    """Distinct moves 0.5 s after identical 2-s label contexts, and the conditional entropy (bits)."""
    outcomes: dict[tuple, Counter] = defaultdict(Counter)
    for clip in clips:
        beats = np.asarray(clip.meta["beats"])
        per_bar, first = clip.meta["beats_per_bar"], clip.meta["first_downbeat"]
        for i, t in enumerate(beats):
            if t < 2.0 or t + 0.5 > clip.texts[-1].end:
                continue
            past = tuple(move_at(clip, b) for b in beats[(beats > t - 2.0) & (beats <= t)])
            key = (clip.meta["dancer"], (i - first) % per_bar, past)
            outcomes[key][move_at(clip, t + 0.5)] += 1
    seen = [np.asarray(list(c.values()), float) for c in outcomes.values() if sum(c.values()) >= 5]
    total = sum(c.sum() for c in seen)
    distinct = sum(len(c) * c.sum() for c in seen) / total
    entropy = -sum(c.sum() / total * float((c / c.sum() * np.log2(c / c.sum())).sum()) for c in seen)
    differ = sum(c.sum() / total * (1 - (c * (c - 1)).sum() / (c.sum() * (c.sum() - 1))) for c in seen)
    return {"distinct": distinct, "entropy": entropy, "differ": differ, "contexts": len(seen)}


def validity(clips: list) -> tuple[float, float]:
    """``move_validity`` of the dances and of the same dances played backwards (to the same beats)."""
    forward, backward = [], []
    for c in clips:
        p, beats = c.motion.skeleton_motion.positions(), np.asarray(c.meta["beats"])
        forward.append(JointClip(c.name, p, FPS, None, beats))
        backward.append(JointClip(c.name, p[::-1].copy(), FPS, None, beats))
    metric = MoveValidity()
    return metric(forward).values["move_validity"], metric(backward).values["move_validity"]


def main() -> None:
    """Build the three sets and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--songs", type=int, default=16)
    parser.add_argument("--dances", type=int, default=6)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    start = time.perf_counter()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"{args.songs} songs x {args.dances} dances x {args.seconds:g} s, seed {args.seed}; "
          f"{platform.machine()}, {cores} cores\n")
    print("| set | NN past distance (m) | NN future error (m) | future / past | 8-NN future spread (m) "
          "| 8-NN distinct next moves | label contexts: distinct next moves | P(two next moves differ) "
          "| H(next move \\| context) (bits) |")
    print("|---|---|---|---|---|---|---|---|---|")
    valid = {}
    for label, options in SETS.items():
        clips = [make_clip(i, seed=args.seed, seconds=args.seconds, bpm=(80.0, 140.0), rate=8000, fps=FPS,
                           dances_per_song=args.dances, **options) for i in range(args.songs * args.dances)]
        songs = [i // args.dances for i in range(len(clips))]
        nn, lab = nearest_neighbour(clips, songs), label_contexts(clips)
        valid[label] = validity(clips)
        print(f"| {label} | {nn['past']:.3f} | {nn['future']:.3f} | {nn['ratio']:.2f} | {nn['spread']:.3f} "
              f"| {nn['distinct']:.2f} "
              f"| {lab['distinct']:.2f} | {lab['differ']:.2f} | {lab['entropy']:.2f} |", flush=True)
    print("\n| set | move-validity | played backwards |\n|---|---|---|")
    for label, (forward, backward) in valid.items():
        print(f"| {label} | {forward:.3f} | {backward:.3f} |")
    print(f"\n{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
