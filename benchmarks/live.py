"""``dance live`` at real time: latency, drops and beat locking of the live dance against the offline one.

For each song, the song is piped as raw s16le PCM into ``dance live default --input - --output - --json``
at ``--speed`` times real time (1 = as a player would), and the JSON Lines frames read back:

* **latency** (ms, p50/p95/max): from the arrival of the audio block that completes the newest music frame
  a dance frame reads, to the frame handed to the sinks (the summary of ``--json``);
* **drops**: frames the model skipped because it fell more than 0.25 s behind;
* **beat locking** (``dance_core.evaluation.body_locking``: the body's own accents on the music's
  beats, whatever the phase, against the wrong-tempo control) of the live dance and of the offline dance
  of the same song (``dance compose``'s generation through ``dance_core.api.Composer``, not grounded:
  live poses are not), on the offline beat tracker's beats, over the whole song and after its first 5 s.

    python benchmarks/live.py [--songs A.ogg B.ogg] [--speed 1] [--json]
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


def pcm(path: Path) -> tuple[bytes, float]:
    """A song as s16le mono PCM at RATE, and its length in seconds."""
    from dance_audio.timing import resample
    from dance_core import get_registry, load_audio

    audio = load_audio(path, get_registry())
    y = resample(audio.samples, audio.rate, RATE)
    return (np.clip(y, -1, 1) * 32767).astype("<i2").tobytes(), len(y) / RATE


def live(path: Path, speed: float) -> tuple[dict, list[dict]]:
    """The summary and frames of ``dance live`` fed the song at ``speed`` times real time."""
    data, _ = pcm(path)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "dance_core.cli.main", "live", "default", "--input", "-", "--rate",
                             str(RATE), "--output", "-", "--json"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env)

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--songs", nargs="+", type=Path, default=[AUDIO / "vibe_ace.ogg", AUDIO / "lets_go_fishin.ogg"])
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    import torch

    from dance_audio.beats import track_beats
    from dance_core import get_registry, load_audio
    from dance_core.api import Composer, load_recipe

    torch.set_num_threads(1)
    composer = Composer(load_recipe("default"))
    rows = []
    for song in args.songs:
        summary, frames = live(song, args.speed)
        names = composer.checkpoint.motion.skeleton.names
        fps = summary["fps"]
        live_pos = np.array([f["positions"] for f in frames])
        beats = track_beats(load_audio(song, get_registry())).times
        s = composer.song(song)
        offline = composer.generate(s)
        data = composer.checkpoint.motion.decode(composer.checkpoint.stats.motion.invert(offline[0]), fps,
                                                 composer.registry)
        off_pos = data.skeleton_motion.positions()
        lat = summary["latency_ms"]
        row = {"song": song.name, "seconds": summary["music_seconds"], "speed": args.speed,
               "frames": summary["frames"], "dropped": summary["dropped_frames"], "latency_ms": lat,
               "music_delay_s": summary["music_delay_s"],
               "live": locking(live_pos, fps, names, beats), "offline": locking(off_pos, fps, names, beats),
               "live_after_5s": locking(live_pos, fps, names, beats, 5.0),
               "offline_after_5s": locking(off_pos, fps, names, beats, 5.0)}
        rows.append(row)
        if not args.json:
            print(f"{song.name}: {row['frames']} frames, {row['dropped']} dropped, latency p50 {lat['p50']:.1f} "
                  f"p95 {lat['p95']:.1f} max {lat['max']:.1f} ms; locking live {row['live']['locking']:.2f} "
                  f"(control {row['live']['control']:.2f}) offline {row['offline']['locking']:.2f} "
                  f"(control {row['offline']['control']:.2f}); after 5 s live {row['live_after_5s']['locking']:.2f} "
                  f"offline {row['offline_after_5s']['locking']:.2f}", flush=True)
    if args.json:
        print(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
