"""Beat tracking accuracy of dance-audio's licence-clean trackers: synthesized songs with known beats,
and the fixture songs against madmom's tracker.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/beat_tracking.py [--songs 40] [--seed 3000]
        [--seconds 30] [--trackers flux librosa] [--music SONG ...] [--readme]

**Synthesized songs** (``dance_core.synth.music.synthesize``): song ``k`` draws from
``numpy.random.default_rng(seed + k)`` a mean tempo of 70-180 BPM and a tempo drift of 2-8 %
(smooth, over tens of beats), everything else (groove, 3/4 or 4/4, swing, instruments, noise) as
the synthesizer draws it; the reference is the song's true beats. **Fixture songs**
(``../shared/fixtures/audio/*.ogg``): the reference is madmom's DBN downbeat tracker on its
network (dance-audio's exact port, ``tracker: madmom``), itself only a reference: it reads madmom's
non-commercial weights, so that column is left out when the madmom extra is missing.

Every tracker runs as the ``beats`` extractor calls it (``track_beats``, its default range
55-160 BPM). Scores per song: **F** the beat F-measure at ±70 ms (one-to-one matches; no
beats skipped at the start); **F any level** the best F against the reference, its double
(midpoints added) and either half (every other beat): right beats at another metrical level;
**tempo** 60 / the median beat interval; **octave %** songs whose tempo is within 8 % of the
reference's double, half, or a third/two thirds (a metrical-level error rather than a wrong beat);
**downbeat F** the F-measure of the bar starts (against the true ones, or madmom's).
Songs above 160 BPM can only be tracked at half tempo by design (the dance prior of the range).
``--readme`` writes the tables into benchmarks/README.md between the ``beats`` markers.
"""

from __future__ import annotations

import argparse
import datetime
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
WINDOW = 0.07


def f_measure(detected: np.ndarray, reference: np.ndarray, window: float = WINDOW) -> float:
    """Beat F-measure: each reference beat matches at most one detection within ``window`` s
    (greedy by distance, in time order)."""
    detected, reference = np.sort(np.asarray(detected)), np.sort(np.asarray(reference))
    if len(detected) == 0 or len(reference) == 0:
        return 0.0
    free = np.ones(len(detected), dtype=bool)
    hits = 0
    for r in reference:
        dist = np.where(free, np.abs(detected - r), np.inf)
        k = int(np.argmin(dist))
        if dist[k] <= window:
            free[k] = False
            hits += 1
    if hits == 0:
        return 0.0
    precision, recall = hits / len(detected), hits / len(reference)
    return 2 * precision * recall / (precision + recall)


def metrical_variants(reference: np.ndarray) -> list[np.ndarray]:
    """The reference, its double (midpoints added) and both halves (every other beat)."""
    reference = np.sort(np.asarray(reference))
    double = np.sort(np.concatenate([reference, (reference[1:] + reference[:-1]) / 2]))
    return [reference, double, reference[0::2], reference[1::2]]


def tempo(times: np.ndarray) -> float:
    """60 / the median beat interval (0 with fewer than two beats)."""
    return float(60.0 / np.median(np.diff(times))) if len(times) > 1 else 0.0


def octave_error(found: float, reference: float) -> bool:
    """The tempo is within 8 % of another metrical level of the reference's (x2, x1/2, x3, x1/3, x2/3, x3/2)."""
    if found <= 0 or reference <= 0:
        return False
    return any(abs(found / (reference * k) - 1) <= 0.08 for k in (2.0, 0.5, 3.0, 1 / 3, 2 / 3, 1.5))


def score(times: np.ndarray, reference: np.ndarray, downbeats: np.ndarray, ref_downbeats: np.ndarray
          ) -> dict[str, float]:
    """F, F at any metrical level, tempo and whether it is an octave error, and downbeat F, of one song."""
    found, ref_tempo = tempo(times), tempo(reference)
    return {
        "f": f_measure(times, reference),
        "downbeat_f": f_measure(downbeats, ref_downbeats),
        "f_any": max(f_measure(times, v) for v in metrical_variants(reference)),
        "tempo": found,
        "ref_tempo": ref_tempo,
        "octave": float(octave_error(found, ref_tempo)),
    }


def synth_songs(n: int, seed: int, seconds: float):
    """``(name, Audio, true beats, true downbeats, label)`` of ``n`` synthesized songs with tempo drift."""
    from dance_core import Audio
    from dance_core.synth import synthesize

    for k in range(n):
        rng = np.random.default_rng(seed + k)
        bpm, drift = float(rng.uniform(70, 180)), float(rng.uniform(0.02, 0.08))
        song = synthesize(seconds, bpm, 22050, rng, drift=drift)
        label = f"{song.style} {song.beats_per_bar}/4, swing {song.swing:.2f}, drift {100 * drift:.0f} %"
        yield f"synth-{seed + k}", Audio(song.audio, song.rate), song.beats, song.downbeats, label


def run_tracker(audio, tracker: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Beat and downbeat times by ``tracker`` and the seconds it took."""
    from dance_audio.beats import track_beats

    start = time.perf_counter()
    beats = track_beats(audio, tracker)
    took = time.perf_counter() - start
    return np.asarray(beats.times, dtype=np.float64), np.asarray(beats.downbeats, dtype=np.float64), took


def summary_row(label: str, tracker: str, rows: list[dict[str, float]], seconds: float) -> str:
    """One markdown row: means of F and F any level, octave errors, tracking time per minute of audio."""
    f = np.array([r["f"] for r in rows])
    f_any = np.array([r["f_any"] for r in rows])
    downbeat = np.mean([r["downbeat_f"] for r in rows])
    octave = 100 * np.mean([r["octave"] for r in rows])
    per_minute = sum(r["time"] for r in rows) / (seconds / 60)
    return (f"| {label} | `{tracker}` | {len(rows)} | **{f.mean():.3f}** | {np.median(f):.3f} | {f_any.mean():.3f} | "
            f"{np.mean(f >= 0.9) * 100:.0f} | {octave:.0f} | {downbeat:.3f} | {per_minute:.2f} |")


def machine() -> str:
    """Machine and load, for the record."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{platform.machine()}, {os.cpu_count()} cores, load average {load:.1f}"


def main(argv: list[str] | None = None) -> None:
    """Track, score, print the tables, optionally write the README section."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--songs", type=int, default=40, help="synthesized songs (default 40)")
    parser.add_argument("--seed", type=int, default=3000, help="seed of the first song (default 3000)")
    parser.add_argument("--seconds", type=float, default=30.0, help="length of each synthesized song (default 30)")
    parser.add_argument("--trackers", nargs="+", default=["flux", "librosa"], help="trackers to compare")
    parser.add_argument("--music", nargs="+", type=Path, help=f"real songs (default: {DEFAULT_MUSIC}/*.ogg)")
    parser.add_argument("--date", default=datetime.date.today().isoformat(), help="date for --readme")
    parser.add_argument("--readme", action="store_true", help="write the tables into benchmarks/README.md")
    args = parser.parse_args(argv)

    from dance_audio.madmom_compat import madmom_available
    from dance_core import get_registry, load_audio

    results: dict[tuple[str, str], list[dict[str, float]]] = {}
    seconds = {"synth": 0.0, "fixtures": 0.0}
    per_song: list[str] = []
    for name, audio, beats, downbeats, label in synth_songs(args.songs, args.seed, args.seconds):
        seconds["synth"] += audio.duration
        cells = []
        for tracker in args.trackers:
            times, bars, took = run_tracker(audio, tracker)
            row = score(times, beats, bars, downbeats) | {"time": took}
            results.setdefault(("synth", tracker), []).append(row)
            cells.append(f"{tracker} F {row['f']:.2f} ({row['tempo']:.0f} BPM)")
        print(f"{name} [{label}] {tempo(beats):.0f} BPM: " + ", ".join(cells), file=sys.stderr, flush=True)
    songs = args.music or sorted(DEFAULT_MUSIC.glob("*.ogg"))
    if songs and not madmom_available():
        print("madmom extra missing: no reference beats for the real songs", file=sys.stderr)
        songs = []
    for song in songs:
        audio = load_audio(song, get_registry())
        seconds["fixtures"] += audio.duration
        reference, ref_bars, _ = run_tracker(audio, "madmom")
        cells = []
        for tracker in args.trackers:
            times, bars, took = run_tracker(audio, tracker)
            row = score(times, reference, bars, ref_bars) | {"time": took}
            results.setdefault(("fixtures", tracker), []).append(row)
            cells.append(f"F {row['f']:.2f}, F any {row['f_any']:.2f}, {row['tempo']:.0f} BPM")
        per_song.append(f"| {song.stem} | {audio.duration:.0f} | {tempo(reference):.0f} | " + " | ".join(cells) + " |")
        print(per_song[-1], file=sys.stderr, flush=True)

    command = "benchmarks/beat_tracking.py " + shlex.join(
        a for a in (argv if argv is not None else sys.argv[1:]) if a != "--readme")
    lines = [
        f"Command: `OMP_NUM_THREADS=1 .venv/bin/python {command.strip()}`; {args.date}; {machine()}.",
        "",
        "| songs | tracker | n | mean F (±70 ms) | median F | mean F any level | songs F ≥ 0.9 (%) "
        "| metrical-level errors (%) | mean downbeat F | seconds per minute of audio |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    labels = {"synth": f"synthesized, {args.seconds:g} s, 70-180 BPM, drift 2-8 % (true beats)",
              "fixtures": "fixture songs (madmom's beats)"}
    for (group, tracker), rows in results.items():
        lines.append(summary_row(labels[group], tracker, rows, seconds[group]))
    if per_song:
        lines += ["", "| fixture song | s | madmom BPM | " + " | ".join(f"`{t}`" for t in args.trackers) + " |",
                  "|---|---|---|" + "---|" * len(args.trackers)] + per_song
    text = "\n".join(lines)
    print(text)
    if args.readme:
        write_section("beats", text)


if __name__ == "__main__":
    main()
