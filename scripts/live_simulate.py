"""``dance live``'s pipeline in-process without real time, scored as ``benchmarks/live.py`` scores the real-time
run: the dance's quality (beat locking, floor and motion against the offline dance) free of the machine's load.

Each song's samples go through 16-bit PCM (as ``benchmarks/live.py`` pipes them into ``dance live``), then in
blocks of 1024 through the live features; the beat tracker's rows and settled beats reach the beat
clock through the session's ``BeatFeed`` (up to the music each frame waited for: the same dance as a session
gives, however its audio arrives); the model steps as soon as its music is known and every frame is posed
(``LivePoses``: grounding, beat lock). No latency, no drops.
``--lookahead S`` sets the grounding's look-ahead (0: the causal grounding), to compare.

    python scripts/live_simulate.py [--lookahead 0.25] [--songs A.ogg B.ogg] [--json]
        [--recipe tm2d-small --model-lookahead 0.5 --seconds 30] [--seeds 3] [--max-rate 1.35]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import live as bench  # noqa: E402  benchmarks/live.py: samples, compare


def simulate(composer, song: Path, lookahead: float, model_lookahead: float | None = None,
             seconds: float | None = None, generated: list | None = None,
             max_rate: float | None = None) -> tuple[dict, list[dict]]:
    """A summary and frames as ``bench.live`` gives them, from the pipeline run without real time; the model's
    own frames (normalized, before decoding) are appended to ``generated`` when it is given; ``max_rate``: the beat
    lock's rate bound (default its ``MAX_RATE``)."""
    from dance_core.live.beat_lock import BeatClock, BeatFeed
    from dance_core.live.features import LiveFeatures
    from dance_core.live.generator import LiveGenerator
    from dance_core.live.pose import LivePoses, PoseDecoder
    from dance_core.live.session import frame_message

    fps = composer.recipe.fps
    # through 16-bit PCM, as benchmarks/live.py pipes it and the session reads it: tm2d-small's dance on vibe_ace
    # moves at 0.63 m/s from the float samples and at 0.29 from the same song at 16 bits
    y = np.frombuffer(bench.pcm(bench.samples(song, seconds)), "<i2").astype(np.float32) / 32768.0
    trackers = frozenset(e.name for e in composer.registry.entries("feature") if e.info.get("beats"))
    features = LiveFeatures(composer.stack, composer.checkpoint, bench.RATE, trackers)
    generator = LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device,
                              None if model_lookahead is None else int(round(model_lookahead * fps)))
    clock = BeatClock(fps)
    poses = LivePoses(PoseDecoder(composer.checkpoint, composer.registry, fps), composer.recipe.compose.ground,
                      clock, lookahead)
    if max_rate is not None and poses.lock is not None:
        poses.lock.max_rate = max_rate
    frames, feed = [], BeatFeed(clock)
    blocks = [y[lo : lo + 1024] for lo in range(0, len(y), 1024)]
    for block in [*blocks, None]:
        streams = features.push(block) if block is not None else features.finish()
        feed.add(features.take_beats(), features.take_settled())
        generator.add(streams)
        if block is None:
            generator.end()
        while generator.ready() > 0:
            first = generator.t
            for offset, frame in enumerate(generator.step()):
                if generated is not None:
                    generated.append(np.asarray(frame, np.float32))
                feed.advance(generator.newest(first + offset))
                frames.append(frame_message(first + offset, fps, poses(first + offset, frame)))
    lag = np.asarray(poses.lock.lags) if poses.lock is not None else np.zeros(1)
    summary = {"fps": fps, "music_seconds": len(y) / bench.RATE, "frames": len(frames), "dropped_frames": 0,
               "latency_ms": {}, "latency_ms_by_minute": [], "music_delay_s": None,
               "grounding_lookahead_s": poses.lookahead, "load_avg": None,
               "beat_lock": {"lag_s": {"mean": round(float(lag.mean()), 3), "max": round(float(lag.max()), 3)}}}
    return summary, frames


def main() -> None:
    """Simulate each song and print how its live dance compares with the offline one."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--songs", nargs="+", type=Path,
                        default=[bench.AUDIO / "vibe_ace.ogg", bench.AUDIO / "lets_go_fishin.ogg"])
    parser.add_argument("--lookahead", type=float, default=0.25, help="the grounding's look-ahead (s; 0: causal)")
    parser.add_argument("--recipe", default="default", help="the recipe danced (default: default)")
    parser.add_argument("--model-lookahead", type=float,
                        help="dance live --lookahead: seconds of music a song-level model waits for (tm2d-small)")
    parser.add_argument("--seconds", type=float, help="each song's first seconds only")
    parser.add_argument("--seeds", type=int, help="dance each song with seeds 0 .. N-1 (default: the recipe's seed)")
    parser.add_argument("--max-rate", type=float, help="the beat lock's rate bound (default: beat_lock.MAX_RATE)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    bench.compare(args.songs, lambda composer, song: simulate(composer, song, args.lookahead, args.model_lookahead,
                                                              args.seconds, max_rate=args.max_rate),
                  args.json, {"simulated": True, "lookahead": args.lookahead, "recipe": args.recipe,
                              "model_lookahead": args.model_lookahead, "max_rate": args.max_rate},
                  args.recipe, args.seconds, args.seeds)


if __name__ == "__main__":
    main()
