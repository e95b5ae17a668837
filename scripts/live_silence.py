"""The live figure at rest in silence: where the gate rests on real songs, and how still and how smooth the
figure is across pauses, against ``--silence off``.

1. **The gate alone** (``dance_core.live.silence.SilenceGate``, no model): each song as it is and
   ``--gain-db`` quieter (a quiet recording), the seconds at rest (weight at least 0.5) and where. Control: a
   fixed -40 dBFS floor without the loudest-second rule, which rests through a quiet recording's music.
2. **The dance** (``dance_core.live.session.LiveSession`` in-process on a file at ``--speed``, no drops):
   each song's first ``--seconds`` with 6 s of silence before it and 4 s of silence inserted halfway, danced
   with the gate and with ``--silence off``: the mean joint speed (m/s) where the gate has settled at rest
   (from ``HOLD + EASE_IN`` = 1.5 s into each silence to ``AHEAD`` = 0.4 s before its end) and in the music
   (from 1 s after it starts), and
   the fastest joint (m/s) within 1 s of each silence's start and end against the 99th percentile of the
   fastest joint in the music.

    python scripts/live_silence.py [--recipe default] [--songs A.ogg ...] [--seconds 20] [--gain-db -30]
"""

from __future__ import annotations

import argparse
import io
import json
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
AUDIO = ROOT.parent / "shared" / "fixtures" / "audio"
RATE = 22050


def rest_spans(y: np.ndarray, rate: int, fps: float, gate=None) -> tuple[float, list[tuple[float, float]]]:
    """Seconds at rest and the spans (s) of a song pushed through a gate in 0.1-s blocks."""
    from dance_core.live.silence import SilenceGate

    gate = gate or SilenceGate(fps, rate)
    block, ahead, weights = rate // 10, 8, []  # ahead: the default model's newest frame less one, past each frame
    for lo in range(0, len(y), block):  # each frame's weight once its music is heard, as a session asks
        gate.push(y[lo : lo + block])
        while len(weights) + ahead < gate.frames:
            weights.append(gate.weight(len(weights), len(weights) + ahead))
    weights += [gate.weight(i, gate.frames - 1) for i in range(len(weights), gate.frames)]
    rest = np.array(weights) >= 0.5
    edges = np.flatnonzero(np.diff(np.r_[0, rest.astype(int), 0])).reshape(-1, 2) / fps
    return float(rest.sum() / fps), [(round(a, 2), round(b, 2)) for a, b in edges]


def fixed_floor(fps: float, rate: int):
    """The control gate: a ``SilenceGate`` silent below -40 dBFS, whatever was heard."""
    from dance_core.live.silence import SilenceGate

    class FixedFloor(SilenceGate):
        def quiet(self, level: float) -> bool:
            return level < -40.0

    return FixedFloor(fps, rate)


def dance(composer, y: np.ndarray, speed: float, silence: float | None) -> np.ndarray:
    """Joint positions ``(T, J, 3)`` of the live dance of ``y`` (mono at RATE)."""
    import soundfile as sf

    from dance_core.live.session import LiveSession
    from dance_core.live.sinks import JsonLinesSink
    from dance_core.live.sources import FileSource

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "song.wav"
        sf.write(path, y, RATE)
        out = io.BytesIO()
        out.close = lambda: None
        source = FileSource(str(path), composer.registry, composer.recipe.format_options, speed=speed)
        summary = LiveSession(composer, source, [JsonLinesSink(out)], max_lag=60, silence=silence).run()
    assert summary["dropped_frames"] == 0
    return np.array([json.loads(line)["positions"] for line in out.getvalue().decode().splitlines()[1:]])


def main() -> None:
    """Both parts, printed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="default")
    parser.add_argument("--songs", nargs="+", type=Path, default=sorted(AUDIO.glob("*.ogg")))
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--gain-db", type=float, default=-30.0)
    parser.add_argument("--speed", type=float, default=8.0)
    args = parser.parse_args()
    import torch

    from dance_audio.timing import resample
    from dance_core import get_registry, load_audio
    from dance_core.api import Composer
    from dance_core.live.silence import AHEAD, EASE_IN, FLOOR_DB, HOLD
    from dance_core.recipe import load_recipe

    torch.set_num_threads(1)
    composer = Composer(load_recipe(args.recipe, []))
    fps = composer.recipe.fps
    gain = 10 ** (args.gain_db / 20)
    print(f"# the gate on whole songs (seconds at rest, spans); quiet: {args.gain_db:g} dB")
    songs = {}
    for song in args.songs:
        audio = load_audio(song, get_registry())
        y = songs[song] = resample(audio.samples, audio.rate, RATE)
        loud, spans = rest_spans(y, RATE, fps)
        quiet, _ = rest_spans(gain * y, RATE, fps)
        control, _ = rest_spans(gain * y, RATE, fps, fixed_floor(fps, RATE))
        print(f"{song.stem}: {len(y) / RATE:.0f} s; at rest {loud:.2f} s {spans}; quiet {quiet:.2f} s; "
              f"control (fixed -40 dBFS) quiet {control:.2f} s")
    print("# the dance across pauses: mean joint speed at rest / in music (m/s); fastest joint at the pauses' edges"
          " / music p99 (m/s)")
    for song, y in songs.items():
        half = int(args.seconds / 2 * RATE)
        quiet = [np.zeros(6 * RATE, np.float32), np.zeros(4 * RATE, np.float32)]
        track = np.concatenate([quiet[0], y[:half], quiet[1], y[half : 2 * half]])
        pauses = [(0.0, 6.0), (6.0 + half / RATE, 10.0 + half / RATE)]
        music = [(6.0, 6.0 + half / RATE), (10.0 + half / RATE, len(track) / RATE)]
        row = []
        for silence in (FLOOR_DB, None):
            p = dance(composer, track, args.speed, silence)
            t = np.arange(len(p) - 1) / fps
            speed = np.linalg.norm(np.diff(p, axis=0), axis=2) * fps  # (T - 1, J)
            rest = np.zeros(len(t), bool)
            for a, b in pauses:
                rest |= (t >= a + HOLD + EASE_IN) & (t < b - AHEAD)
            playing = np.zeros(len(t), bool)
            for a, b in music:
                playing |= (t >= a + 1.0) & (t < b)
            edges = np.zeros(len(t), bool)
            for a, b in pauses:
                edges |= (np.abs(t - a) < 1.0) | (np.abs(t - b) < 1.0)
            edges &= t > 1.5  # not the session's first pose
            fastest = speed.max(1)
            row.append(f"{'on' if silence is not None else 'off'}: {speed[rest].mean():.3f} / "
                       f"{speed[playing].mean():.3f}; {fastest[edges].max():.2f} / "
                       f"{np.percentile(fastest[playing], 99):.2f}")
        print(f"{song.stem}: " + "; ".join(row))


if __name__ == "__main__":
    main()
