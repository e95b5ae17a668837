"""``dance live`` at real time: latency, drops, beat locking, grounding and motion of the live dance against
the offline one.

For each song, the song is piped as raw s16le PCM into ``dance live default --input - --output - --json``
at ``--speed`` times real time (1 = as a player would), and the JSON Lines frames read back:

* **latency** (ms, p50/p95/max, and per minute of music): from the arrival of the audio block that completes
  the newest music frame a dance frame reads, to the frame handed to the sinks (the summary of ``--json``);
* **drops**: frames the model skipped because it fell more than 0.25 s behind;
* **beat locking** (``dance_core.evaluation.body_locking``: the body's own accents on the music's
  beats, whatever the phase, against the wrong-tempo control) of the live dance and of the offline dance
  of the same song (``dance compose``'s: generated, grounded and beat-aligned, through
  ``dance_core.api.Composer``), on the offline beat tracker's beats, over the whole song and after its
  first 5 s;
* **grounding and motion** (``dance_core.evaluation.quality_scores`` on the soles): frames floating (both
  soles over 5 cm up), foot skating, mean joint speed and jerk, live against offline;
* **realism** (``benchmarks/realism.py``'s measure): the Fréchet distance of the dance's 4-s window statistics
  to the 7 held-out real CMU takes, in units of the real scale (the takes' halves against each other), the
  statistics whose median lies inside the takes' 10-90 % range, and the knees' bend, live against offline.

``--minutes M`` instead plays one long song, the fixture songs one after another until ``M`` minutes, and
reports the latency per minute (does it grow?); no offline dance.

``scripts/live_simulate.py`` runs the same pipeline in-process without real time and scores it with this
file's functions (:func:`compare`): the dance's quality free of the machine's load.

``--load N`` runs N busy processes (a Python loop each, at normal priority) on the same cores while ``dance
live`` plays: a deliberate competing load, under which frames are dropped and counted, never the audio.
Every row reports the machine's load average (``os.getloadavg``) before and after the song plays.

    python benchmarks/live.py [--songs A.ogg B.ogg] [--speed 1] [--minutes 10] [--load 2] [--json]
        [--recipe tm2d-small --lookahead 0.5 --seconds 30]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
AUDIO = ROOT.parent / "shared" / "fixtures" / "audio"
RATE = 22050


def samples(path: Path, seconds: float | None = None) -> np.ndarray:
    """A song's mono samples at RATE (dance-audio's reader), its first ``seconds`` when given."""
    from dance_audio.timing import resample
    from dance_core import get_registry, load_audio

    audio = load_audio(path, get_registry())
    y = resample(audio.samples, audio.rate, RATE)
    return y if seconds is None else y[: int(seconds * RATE)]


def pcm(y: np.ndarray) -> bytes:
    """Samples as s16le mono PCM."""
    return (np.clip(y, -1, 1) * 32767).astype("<i2").tobytes()


def long_song(minutes: float) -> np.ndarray:
    """The fixture songs one after another, again from the first, cut at ``minutes``."""
    songs = [samples(p) for p in sorted(AUDIO.glob("*.ogg"))]
    parts, total = [], 0
    while total < minutes * 60 * RATE:
        for y in songs:
            parts.append(y)
            total += len(y)
    return np.concatenate(parts)[: int(minutes * 60 * RATE)]


def busy(n: int) -> list[subprocess.Popen]:
    """``n`` processes that keep a core busy until they are ended (the competing load of ``--load``)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def load_average() -> list[float]:
    """The machine's 1-, 5- and 15-minute load averages."""
    return [round(x, 2) for x in os.getloadavg()]


def live(data: bytes, speed: float, load: int = 0, recipe: str = "default", extra: tuple[str, ...] = ()
         ) -> tuple[dict, list[dict]]:
    """The summary and frames of ``dance live RECIPE`` (with ``extra`` options) fed PCM ``data`` at ``speed``
    times real time, with ``load`` busy processes beside it; the summary gains the load averages before and
    after (``load_avg``)."""
    before = load_average()
    hogs = busy(load)
    try:
        summary, frames = _live(data, speed, recipe, extra)
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    summary["load_avg"] = {"before": before, "after": load_average(), "busy_processes": load}
    return summary, frames


def _live(data: bytes, speed: float, recipe: str, extra: tuple[str, ...]) -> tuple[dict, list[dict]]:
    """The summary and frames of ``dance live`` fed PCM ``data`` at ``speed`` times real time."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "dance_core.cli.main", "live", recipe, "--input", "-", "--rate",
                             str(RATE), "--output", "-", "--json", *extra], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)

    def feed() -> None:
        time.sleep(8.0)  # the model loads first (a player would start once it is up)
        block, begin = 1024, time.perf_counter()
        for k, lo in enumerate(range(0, len(data), 2 * block)):
            wait = begin + k * block / RATE / speed - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            proc.stdin.write(data[lo : lo + 2 * block])
            proc.stdin.flush()
        proc.stdin.close()

    threading.Thread(target=feed, daemon=True).start()
    out = proc.stdout.read()
    err = proc.stderr.read().decode()
    proc.wait()
    if proc.returncode != 0:
        raise SystemExit(f"dance live failed: {err.strip()}")
    lines = [json.loads(line) for line in out.decode().splitlines()]
    return json.loads(err[err.index("{") :]), lines[1:]


def locking(positions: np.ndarray, fps: float, names: list[str], beats: np.ndarray, start: float = 0.0) -> dict:
    """Body locking of a dance from ``start`` seconds on."""
    from dance_core.evaluation import body_locking

    first = int(round(start * fps))
    music = beats[beats >= start] - start
    return body_locking(positions[first:], fps, names, music)


def floor_and_motion(motion, beats: np.ndarray) -> dict:
    """Floating, skating, speed and jerk of a dance (``quality_scores`` on its soles)."""
    from dance_core.evaluation import quality_scores
    from dance_core.motion import soles

    p = motion.positions()
    q = quality_scores(p, motion.fps, beats, motion.skeleton.names, motion.skeleton.parents, soles(motion))
    return {k: q[k] for k in ("float", "below_floor", "skating", "speed", "jerk")}


class Realism:
    """The held-out real takes' window statistics, loaded on first use, to score a dance's realism against."""

    def __init__(self):
        self.reference = self.scale = None

    def __call__(self, motion) -> dict:
        """``distance`` (× the real scale), ``inside`` (statistics in the real 10-90 % range) and ``knee_bend``
        (median, degrees) of a skeletal motion."""
        import realism

        from dance_core.evaluation import STATISTICS, realism_distance

        if self.reference is None:
            takes = realism.real_takes(realism.MOCAP)
            held = [takes[n] for n in realism.HELD_OUT]
            self.reference = np.concatenate([realism.stats(m) for m in held])
            first, second = (np.concatenate([realism.stats(realism.halves(m)[k]) for m in held]) for k in (0, 1))
            self.scale = (realism_distance(first, second) + realism_distance(second, first)) / 2
        windows = realism.stats(motion.resample(realism.FPS))
        if len(windows) < 2:
            return {"distance": float("nan"), "inside": 0, "knee_bend": float("nan")}
        lo, hi = np.percentile(self.reference, [10, 90], axis=0)
        median = np.median(windows, axis=0)
        return {"distance": realism_distance(windows, self.reference) / self.scale,
                "inside": int(((median >= lo) & (median <= hi)).sum()),
                "knee_bend": float(median[STATISTICS.index("knee_bend")])}


def minutes_table(summary: dict) -> str:
    """The latency per minute of music, one line."""
    return "; ".join(f"min {i + 1}: p50 {m['p50']:.1f} p95 {m['p95']:.1f} max {m['max']:.0f}"
                     for i, m in enumerate(summary["latency_ms_by_minute"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--songs", nargs="+", type=Path, default=[AUDIO / "vibe_ace.ogg", AUDIO / "lets_go_fishin.ogg"])
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--minutes", type=float, help="play one song this long (the fixtures in a row): latency only")
    parser.add_argument("--load", type=int, default=0, help="busy processes competing for the cores meanwhile")
    parser.add_argument("--recipe", default="default", help="the recipe danced (default: default)")
    parser.add_argument("--lookahead", type=float, help="dance live --lookahead (song-level models: tm2d-small)")
    parser.add_argument("--seconds", type=float, help="each song's first seconds only")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    extra = () if args.lookahead is None else ("--lookahead", str(args.lookahead))

    if args.minutes:
        summary, frames = live(pcm(long_song(args.minutes)), args.speed, args.load, args.recipe, extra)
        row = {"song": f"fixtures in a row, {args.minutes:g} min", "seconds": summary["music_seconds"],
               "frames": summary["frames"], "dropped": summary["dropped_frames"], "latency_ms": summary["latency_ms"],
               "latency_ms_by_minute": summary["latency_ms_by_minute"], "beat_lock": summary.get("beat_lock"),
               "load_avg": summary["load_avg"]}
        lat = row["latency_ms"]
        print(json.dumps(row, indent=2) if args.json else
              f"{row['song']}: {row['frames']} frames, {row['dropped']} dropped, latency p50 {lat['p50']:.1f} p95 "
              f"{lat['p95']:.1f} max {lat['max']:.1f} ms; {minutes_table(summary)}; load {row['load_avg']}")
        return

    compare(args.songs, lambda composer, song: live(pcm(samples(song, args.seconds)), args.speed, args.load,
                                                    args.recipe, extra),
            args.json, {"speed": args.speed, "recipe": args.recipe, "lookahead": args.lookahead}, args.recipe,
            args.seconds)


def seeded(recipe, seeds: int | None) -> list:
    """A composer of ``recipe`` for each seed 0 .. seeds - 1 (the recipe's own seed alone when None)."""
    from dance_core.api import Composer

    if seeds is None:
        return [Composer(recipe)]
    return [Composer(recipe.model_copy(update={"seed": k})) for k in range(seeds)]


def compare(songs: list[Path], play, as_json: bool, extra: dict | None = None, recipe: str = "default",
            seconds: float | None = None, seeds: int | None = None) -> list[dict]:
    """For each song (its first ``seconds``), the live dance of ``recipe`` (``play(composer, song)`` gives
    ``live``'s summary and frames) against the offline one: locking, floor and motion, with the summary's
    latency, drops and load; printed as lines, or as JSON at the end. ``seeds``: each song danced with the
    recipe's seed set to 0 .. seeds - 1 (the recipe's own seed when None)."""
    import torch

    from dance_audio.beats import track_beats
    from dance_core import get_registry, load_audio
    from dance_core.api import load_recipe
    from dance_core.motion import Motion

    torch.set_num_threads(1)
    composers = seeded(load_recipe(recipe), seeds)
    skeleton = composers[0].checkpoint.motion.skeleton
    names = skeleton.names
    rows, real = [], Realism()
    for song, composer in ((song, composer) for song in songs for composer in composers):
        summary, frames = play(composer, song)
        fps = summary["fps"]
        live_motion = Motion(skeleton, fps, np.array([f["root"] for f in frames]),
                             np.array([f["rotations"] for f in frames]))
        live_pos = np.array([f["positions"] for f in frames])
        beats = track_beats(load_audio(song, get_registry())).times
        beats = beats if seconds is None else beats[beats < seconds]
        s = composer.song(song, seconds)
        offline = composer.dances(s, composer.generate(s))[0]  # as dance compose writes it
        off_motion = offline.skeleton_motion
        off_pos = off_motion.positions()
        lat = summary["latency_ms"]
        row = {"song": song.name, "seed": composer.recipe.seed, "seconds": summary["music_seconds"], **(extra or {}),
               "frames": summary["frames"], "dropped": summary["dropped_frames"], "latency_ms": lat,
               "latency_ms_step_first": summary.get("latency_ms_step_first"),
               "latency_ms_by_minute": summary["latency_ms_by_minute"],
               "music_delay_s": summary["music_delay_s"], "beat_lock": summary.get("beat_lock"),
               "grounding_lookahead_s": summary.get("grounding_lookahead_s"), "load_avg": summary["load_avg"],
               "live": locking(live_pos, fps, names, beats), "offline": locking(off_pos, fps, names, beats),
               "live_after_5s": locking(live_pos, fps, names, beats, 5.0),
               "offline_after_5s": locking(off_pos, fps, names, beats, 5.0),
               "live_floor_motion": floor_and_motion(live_motion, beats),
               "offline_floor_motion": floor_and_motion(off_motion, beats),
               "live_realism": real(live_motion), "offline_realism": real(off_motion),
               "offline_meta": {k: offline.meta.get(k) for k in ("grounding", "beat_align")}}
        rows.append(row)
        if not as_json:
            fl, fo = row["live_floor_motion"], row["offline_floor_motion"]
            rl, ro = row["live_realism"], row["offline_realism"]
            timing = (f"{row['frames']} frames, {row['dropped']} dropped, latency p50 {lat['p50']:.1f} p95 "
                      f"{lat['p95']:.1f} max {lat['max']:.1f} ms" if lat else f"{row['frames']} frames, simulated")
            print(f"{song.name} (seed {row['seed']}): {timing}; locking live {row['live']['locking']:.2f} "
                  f"(control {row['live']['control']:.2f}) offline {row['offline']['locking']:.2f} "
                  f"(control {row['offline']['control']:.2f}); after 5 s live {row['live_after_5s']['locking']:.2f} "
                  f"offline {row['offline_after_5s']['locking']:.2f}; float live {fl['float']:.3f} offline "
                  f"{fo['float']:.3f}, skating {fl['skating']:.3f} / {fo['skating']:.3f} m/s, speed "
                  f"{fl['speed']:.2f} / {fo['speed']:.2f} m/s, jerk {fl['jerk']:.0f} / {fo['jerk']:.0f} m/s^3; "
                  f"realism {rl['distance']:.2f} / {ro['distance']:.2f} x the real scale, {rl['inside']} / "
                  f"{ro['inside']} statistics in range, knees {rl['knee_bend']:.1f} / {ro['knee_bend']:.1f} deg; "
                  f"lag {row['beat_lock'] and row['beat_lock'].get('lag_s')}; load {row['load_avg']}",
                  flush=True)
    if as_json:
        print(json.dumps(rows, indent=2))
    return rows


if __name__ == "__main__":
    main()
