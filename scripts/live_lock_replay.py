"""The live beat lock, recorded once and replayed in seconds: a way to try changes to the lock on many dances.

``record`` runs the live pipeline in-process (``scripts/live_simulate.py``'s ``simulate``) for each song and seed
and keeps, in order, what reaches the beat lock (``dance_core.live.beat_lock``): the tracker's phase rows and
settled beats given to the clock, the grounded frames pushed and the output frames asked for; with the offline
dance's scores (``benchmarks/live.py``: locking, floor and motion). The lock sees nothing else, so ``score``
replays these through a lock (today's, or the ``BeatLock`` of another file, e.g. an earlier revision's
``beat_lock.py``) and gives the dance it plays exactly as the live pipeline would, scored against offline's:
body locking and its wrong-tempo control, jerk, skating and speed over offline's, the 99th percentile of the
per-frame jerk (m/s^3) and the share of frames played faster than 2x. ``--against FILE`` scores a second lock
on the same inputs and gives the paired difference in locking with its standard error. ``--oracle heard`` replaces
the live tracker's beats with the offline tracker's (the whole song's) among those heard so far, the music up to
the newest tracker row given to the clock, then extrapolated at their tempo; ``--oracle all`` with every offline
beat: how well the lock would do if the live tracker placed beats as offline does (the lock's share of a
shortfall, against the tracker's).

    python scripts/live_lock_replay.py record DIR --seeds 6 --seconds 60 --songs A.ogg B.wav ...
    python scripts/live_lock_replay.py score DIR [--max-rate 2.3] [--lock FILE.py] [--against FILE.py] [--seeds 0 1 2]
        [--oracle heard|all]
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import live as bench  # noqa: E402  benchmarks/live.py: locking, floor_and_motion
import live_simulate  # noqa: E402

#: event kinds, in the order recorded
UPDATE, SETTLE, PUSH, POSE = range(4)


@contextlib.contextmanager
def recording(events: list):
    """While open, every beat clock and beat lock the live pipeline builds logs its inputs to ``events``."""
    from dance_core.live import beat_lock, pose

    class Clock(beat_lock.BeatClock):
        def update(self, frame, sin, cos):
            events.append((UPDATE, (frame, sin, cos)))
            super().update(frame, sin, cos)

        def settle(self, times):
            events.append((SETTLE, np.array(times, np.float64)))
            super().settle(times)

    class Lock(beat_lock.BeatLock):
        def push(self, frame, root, rotations, positions):
            events.append((PUSH, (frame, np.array(root), np.array(rotations), np.array(positions))))
            super().push(frame, root, rotations, positions)

        def pose(self, frame):
            events.append((POSE, frame))
            return super().pose(frame)

    saved = beat_lock.BeatClock, pose.BeatLock
    beat_lock.BeatClock, pose.BeatLock = Clock, Lock
    try:
        yield
    finally:
        beat_lock.BeatClock, pose.BeatLock = saved


def save(path: Path, events: list, meta: dict) -> None:
    """One dance's events as arrays (``.npz``) beside its scores (``.json``)."""
    kinds = np.array([k for k, _ in events], np.int8)
    pick = {kind: [v for k, v in events if k == kind] for kind in range(4)}
    settled = pick[SETTLE] or [np.zeros(0)]
    pushes = pick[PUSH]
    np.savez_compressed(
        path.with_suffix(".npz"), kinds=kinds, updates=np.array(pick[UPDATE], np.float64).reshape(-1, 3),
        settled=np.concatenate(settled), settled_sizes=np.array([len(s) for s in pick[SETTLE]], np.int64),
        push_frames=np.array([p[0] for p in pushes], np.int64), roots=np.array([p[1] for p in pushes]),
        rotations=np.array([p[2] for p in pushes]), positions=np.array([p[3] for p in pushes]),
        poses=np.array(pick[POSE], np.int64))
    path.with_suffix(".json").write_text(json.dumps(meta))


def record(args) -> None:
    """Simulate each song and seed live, keeping the lock's inputs and the offline dance's scores."""
    import torch

    from dance_audio.beats import track_beats
    from dance_core import get_registry, load_audio
    from dance_core.api import load_recipe

    torch.set_num_threads(1)
    args.out.mkdir(parents=True, exist_ok=True)
    for composer in bench.seeded(load_recipe(args.recipe), args.seeds):
        for song in args.songs:
            dest = args.out / f"{song.stem}-{composer.recipe.seed}"
            if dest.with_suffix(".json").exists():
                continue
            events: list = []
            with recording(events):
                live_simulate.simulate(composer, song, args.lookahead, seconds=args.seconds)
            fps = composer.recipe.fps
            beats = track_beats(load_audio(song, get_registry())).times
            beats = beats if args.seconds is None else beats[beats < args.seconds]
            s = composer.song(song, args.seconds)
            offline = composer.dances(s, composer.generate(s))[0].skeleton_motion
            names = offline.skeleton.names
            save(dest, events, {"recipe": args.recipe, "fps": fps, "beats": beats.tolist(),
                                "offline": bench.locking(offline.positions(), fps, names, beats),
                                "offline_floor_motion": bench.floor_and_motion(offline, beats)})
            print(dest.name, flush=True)


def load_class(path: Path, name: str):
    """The class ``name`` of a Python file (a module of another revision, e.g. its ``beat_lock.py``)."""
    spec = importlib.util.spec_from_file_location(f"revision_{abs(hash(str(path)))}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, name)


def load_lock(path: Path | None):
    """``BeatLock`` of a file (``beat_lock.py`` of another revision), or today's."""
    if path is None:
        from dance_core.live.beat_lock import BeatLock

        return BeatLock
    return load_class(path, "BeatLock")


def oracle_clock(fps: float, beats: np.ndarray, heard_only: bool):
    """A beat clock answering from the offline tracker's ``beats`` (s): those heard so far (up to the newest tracker
    row given to it), then at their tempo (the median of their last intervals), with ``heard_only``; else all."""
    from dance_core.live.beat_lock import SETTLED_TEMPO, BeatClock

    class OracleClock(BeatClock):
        latest = -np.inf  # the newest music time the tracker has given a row for

        def update(self, frame: int, sin: float, cos: float) -> None:
            super().update(frame, sin, cos)
            self.latest = frame / self.fps

        def known(self) -> np.ndarray:
            return beats[beats <= self.latest] if heard_only else beats

        @property
        def period(self) -> float | None:
            known = self.known()
            return float(np.median(np.diff(known[-SETTLED_TEMPO:]))) if len(known) > 2 else None

        def ahead(self, t: float, horizon: float) -> np.ndarray:
            known, period = self.known(), self.period
            if period is None:
                return np.zeros(0)
            extra = known[-1] + period * np.arange(1, int(np.ceil((t + horizon - known[-1]) / period)) + 1)
            out = np.concatenate([known, extra])
            return out[(out > t) & (out <= t + horizon)]

    return OracleClock(fps)


def replay(path: Path, fps: float, lock_class, skeleton, max_rate: float | None, oracle: str | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Root, rotations and positions of the dance ``lock_class`` plays from one recording, output frames from 0
    (those before the first pose asked for hold it), and the lock's rate at each; ``oracle`` (``heard`` or
    ``all``): the offline beats instead of the live tracker's (:func:`oracle_clock`)."""
    from dance_core.live.beat_lock import BeatClock

    with np.load(path.with_suffix(".npz")) as stored:  # read once: an npz member is decompressed on each access
        data = {name: stored[name] for name in stored.files}
    if oracle is None:
        clock = BeatClock(fps)
    else:
        beats = np.array(json.loads(path.with_suffix(".json").read_text())["beats"])
        clock = oracle_clock(fps, beats, oracle == "heard")
    lock = lock_class(skeleton, fps, clock)
    if max_rate is not None:
        lock.max_rate = max_rate
    settled = np.split(data["settled"], np.cumsum(data["settled_sizes"])[:-1]) if len(data["settled_sizes"]) else []
    at = dict.fromkeys(range(4), 0)
    out, rates = {}, {}
    for kind in data["kinds"]:
        k = at[kind]
        at[kind] += 1
        if kind == UPDATE:
            frame, sin, cos = data["updates"][k]
            clock.update(int(frame), float(sin), float(cos))
        elif kind == SETTLE:
            clock.settle(settled[k])
        elif kind == PUSH:
            lock.push(int(data["push_frames"][k]), data["roots"][k], data["rotations"][k], data["positions"][k])
        else:
            frame = int(data["poses"][k])
            out[frame], rates[frame] = lock.pose(frame), lock.rate
    first = min(out)
    frames = [out[max(first, i)] for i in range(max(out) + 1)]
    rate = np.array([rates[max(first, i)] for i in range(max(out) + 1)])
    return tuple(np.array([f[i] for f in frames]) for i in range(3)) + (rate,)


def scores(path: Path, lock_class, skeleton, max_rate: float | None, oracle: str | None = None) -> dict:
    """One recording replayed through ``lock_class`` (on the offline beats with ``oracle``) and scored against the
    offline dance."""
    from dance_core.motion import Motion

    meta = json.loads(path.with_suffix(".json").read_text())
    fps, beats = meta["fps"], np.array(meta["beats"])
    root, rotations, positions, rate = replay(path, fps, lock_class, skeleton, max_rate, oracle)
    locked = bench.locking(positions, fps, skeleton.names, beats)
    motion = bench.floor_and_motion(Motion(skeleton, fps, root, rotations), beats)
    offline = meta["offline_floor_motion"]
    jerk = np.linalg.norm(np.diff(positions, 3, axis=0), axis=-1).mean(1) * fps**3
    return {"locking": locked["locking"], "control": locked["control"], "offline": meta["offline"]["locking"],
            "jerk": motion["jerk"] / offline["jerk"], "skating": motion["skating"] / max(offline["skating"], 1e-9),
            "speed": motion["speed"] / offline["speed"], "jerk_p99": float(np.percentile(jerk, 99)),
            "over_2x": float((rate > 2.0).mean())}


def score(args) -> None:
    """Replay every recording in the directory (of the seeds asked for) and print the means, over all and per song."""
    from dance_core.api import Composer, load_recipe

    paths = sorted(p.with_suffix("") for p in args.dir.glob("*.json"))
    if args.seeds:
        paths = [p for p in paths if int(p.name.rsplit("-", 1)[1]) in args.seeds]
    if not paths:
        sys.exit(f"{args.dir}: no recordings")
    recipe = json.loads(paths[0].with_suffix(".json").read_text())["recipe"]
    skeleton = Composer(load_recipe(recipe)).checkpoint.motion.skeleton
    locks = [load_lock(args.lock)] + ([load_lock(args.against)] if args.against else [])
    rows = [[scores(p, lock, skeleton, args.max_rate, args.oracle) for lock in locks] for p in paths]
    for k, name in enumerate(("lock", "against")[: len(locks)]):
        mean = {key: float(np.nanmean([r[k][key] for r in rows])) for key in rows[0][k]}
        print(f"{name}: {len(rows)} dances; " + ", ".join(f"{key} {v:.3f}" for key, v in mean.items())
              + f"; share of offline's locking {mean['locking'] / mean['offline']:.3f}")
        songs = sorted({p.name.rsplit("-", 1)[0] for p in paths})
        for song in songs:
            mine = [r[k] for r, p in zip(rows, paths, strict=True) if p.name.rsplit("-", 1)[0] == song]
            live, offline, skating, jerk = (np.mean([r[key] for r in mine])
                                            for key in ("locking", "offline", "skating", "jerk"))
            print(f"  {song}: locking {live:.3f} against offline's {offline:.3f} ({live / offline:.0%}), "
                  f"skating {skating:.2f}x, jerk {jerk:.2f}x")
    if args.against:
        diff = np.array([r[0]["locking"] - r[1]["locking"] for r in rows])
        error = diff.std(ddof=1) / np.sqrt(len(diff))
        print(f"lock - against: locking {diff.mean():+.4f} (standard error {error:.4f}), "
              f"better on {(diff > 0).sum()} of {len(diff)}")


def main() -> None:
    """``record`` or ``score``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="simulate live and keep the lock's inputs")
    rec.add_argument("out", type=Path)
    rec.add_argument("--songs", nargs="+", type=Path, default=sorted(bench.AUDIO.glob("*.ogg")))
    rec.add_argument("--seeds", type=int, default=3, help="seeds 0 .. N-1")
    rec.add_argument("--seconds", type=float, default=60.0)
    rec.add_argument("--lookahead", type=float, default=0.1, help="the grounding's look-ahead (s)")
    rec.add_argument("--recipe", default="default")
    sco = sub.add_parser("score", help="replay the recordings through a lock")
    sco.add_argument("dir", type=Path)
    sco.add_argument("--lock", type=Path, help="a beat_lock.py whose BeatLock to replay (default: today's)")
    sco.add_argument("--against", type=Path, help="a second beat_lock.py to compare with, paired")
    sco.add_argument("--max-rate", type=float, help="the lock's rate bound (default: its own)")
    sco.add_argument("--seeds", nargs="+", type=int, help="only these seeds' recordings")
    sco.add_argument("--oracle", choices=("heard", "all"),
                     help="steer to the offline tracker's beats: those heard so far, or all of them")
    args = parser.parse_args()
    record(args) if args.command == "record" else score(args)


if __name__ == "__main__":
    main()
