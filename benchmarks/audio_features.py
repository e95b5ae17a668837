"""Time dance-audio's feature stacks on a 60 s song: warm, in a fresh process, and on a first run
(empty numba cache), and madmom's RNNDownBeatProcessor against dance's NumPy/numba port."""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SONG = REPO.parent / "shared" / "fixtures" / "audio" / "vibe_ace.ogg"
FPS = 30.0
STACKS = {
    "transflower (mel + onset + madmom-downbeat)": ["mel", "onset", "madmom-downbeat"],
    "librosa-438": ["librosa-438"],
    "everything (librosa-438 + mel + onset + madmom-downbeat + beats)": [
        "librosa-438",
        "mel",
        "onset",
        "madmom-downbeat",
        "beats",
    ],
}
RUN_STACK = """
import sys, time, warnings
t0 = time.perf_counter()
from dance_core import get_registry
from dance_core import load_audio
from dance_core import FeatureInputs
warnings.simplefilter("ignore")
reg = get_registry()
audio = load_audio(sys.argv[1], reg)
inputs = FeatureInputs(n_frames=audio.n_frames({fps}), audio=audio)
for name in sys.argv[2:]:
    reg.get("feature", name).build().extract(inputs, {fps})
print(time.perf_counter() - t0)
"""


def song_60s(tmp: Path) -> Path:
    """The first 60 s of a real song (Vibe Ace, jazz) as a WAV file."""
    import soundfile as sf

    y, rate = sf.read(SONG, dtype="float32")
    path = tmp / "song60.wav"
    sf.write(path, y[: 60 * rate], rate)
    return path


def in_process(path: Path, names: list[str], repeats: int = 9) -> tuple[float, float]:
    """(median, fastest) seconds to load and extract in a warm process (fresh Audio each time: no
    cache hits); this shared VM's timings scatter by tens of per cent, hence the many repeats."""
    from dance_core import FeatureInputs, get_registry, load_audio

    reg = get_registry()
    extractors = [reg.get("feature", n).build() for n in names]
    times = []
    for _ in range(repeats + 1):
        t0 = time.perf_counter()
        audio = load_audio(path, reg)
        inputs = FeatureInputs(n_frames=audio.n_frames(FPS), audio=audio)
        for ext in extractors:
            ext.extract(inputs, FPS)
        times.append(time.perf_counter() - t0)
    return statistics.median(times[1:]), min(times[1:])


def per_extractor(path: Path) -> list[tuple[str, float]]:
    """Warm seconds of each extractor alone on the loaded song (decoding excluded)."""
    from dance_core import FeatureInputs, get_registry, load_audio

    reg = get_registry()
    rows = []
    for name in ["mel", "onset", "madmom-downbeat", "beats", "librosa-438"]:
        ext = reg.get("feature", name).build()
        times = []
        for _ in range(3):
            audio = load_audio(path, reg)  # a new Audio object: the spectrogram/activation caches miss
            inputs = FeatureInputs(n_frames=audio.n_frames(FPS), audio=audio)
            t0 = time.perf_counter()
            ext.extract(inputs, FPS)
            times.append(time.perf_counter() - t0)
        rows.append((name, statistics.median(times[1:])))
    return rows


def subprocess_run(path: Path, names: list[str], numba_dir: str | None = None) -> tuple[float, float]:
    """(wall seconds of a whole fresh ``python`` process, seconds inside it from first import)."""
    env = dict(os.environ)
    if numba_dir is not None:
        env["NUMBA_CACHE_DIR"] = numba_dir
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", RUN_STACK.format(fps=FPS), str(path), *names],
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    return time.perf_counter() - t0, float(out.stdout.strip().splitlines()[-1])


def madmom_vs_port(path: Path) -> dict[str, float]:
    """Seconds for madmom's RNNDownBeatProcessor and for the port on the same 44.1 kHz samples."""
    from dance_audio.downbeat_net import downbeat_activations
    from dance_audio.madmom_compat import import_madmom
    from dance_audio.timing import resample
    from dance_core import get_registry, load_audio

    audio = load_audio(path, get_registry())
    y = resample(audio.samples, audio.rate, 44100)
    import_madmom()
    from madmom.audio.signal import Signal
    from madmom.features.downbeats import RNNDownBeatProcessor

    downbeat_activations(y[:44100])  # reads the weights and loads (or compiles) the kernel once
    theirs, ours = [], []
    for _ in range(3):  # alternate, so both see the same machine load; report medians
        t0 = time.perf_counter()
        ref = RNNDownBeatProcessor()(Signal(y, sample_rate=44100))
        t1 = time.perf_counter()
        act = downbeat_activations(y)
        t2 = time.perf_counter()
        theirs.append(t1 - t0)
        ours.append(t2 - t1)
    return {
        "madmom": statistics.median(theirs),
        "port": statistics.median(ours),
        "max_diff": float(np.abs(ref - act).max()),
    }


def stacks(path: Path, tmp: str) -> None:
    """Print the stack table and the per-extractor table."""
    print("\n| stack (60 s song, 30 fps) | warm: median (fastest) of 9 | fresh process | first run (no numba cache) |")
    print("|---|---|---|---|")
    for label, names in STACKS.items():
        subprocess_run(path, names)  # make sure the persistent numba cache is filled
        warm, fastest = in_process(path, names)
        fresh, _ = subprocess_run(path, names)
        first, _ = subprocess_run(path, names, numba_dir=tempfile.mkdtemp(dir=tmp))
        print(f"| {label} | {warm:.2f} s ({fastest:.2f} s) | {fresh:.2f} s | {first:.2f} s |")
    print("\n| extractor alone, warm (60 s song) | seconds |")
    print("|---|---|")
    for name, secs in per_extractor(path):
        print(f"| {name} | {secs:.2f} |")


def long_song(tmp: Path) -> None:
    """Seconds of each extractor on a 20-minute song (a real song looped) and the peak memory."""
    import resource

    import soundfile as sf

    from dance_core import FeatureInputs, get_registry, load_audio

    y, rate = sf.read(SONG.parent / "lets_go_fishin.ogg", dtype="float32")
    y = y.mean(axis=1) if y.ndim > 1 else y
    path = tmp / "song20min.wav"
    sf.write(path, np.tile(y, int(np.ceil(1200 * rate / len(y))))[: 1200 * rate], rate)
    reg = get_registry()
    audio = load_audio(path, reg)
    inputs = FeatureInputs(n_frames=audio.n_frames(FPS), audio=audio)
    print("\n| extractor, 20-minute song (36000 frames), in this order | seconds |")
    print("|---|---|")
    for name in ["mel", "onset", "madmom-downbeat", "beats", "librosa-438"]:
        t0 = time.perf_counter()
        out = reg.get("feature", name).build().extract(inputs, FPS)
        assert np.isfinite(out).all()
        print(f"| {name} | {time.perf_counter() - t0:.1f} |")
    print(f"\npeak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB")


def main() -> None:
    """Print markdown tables of the timings (``--rnn-only``: only madmom against the port;
    ``--long``: only the 20-minute song)."""
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.1f}, python {platform.python_version()}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        if "--long" in sys.argv:
            long_song(Path(tmp))
            return
        path = song_60s(Path(tmp))
        if "--rnn-only" not in sys.argv:
            stacks(path, tmp)
        r = madmom_vs_port(path)
        print("\n| RNNDownBeatProcessor, 60 s (median of 3) | seconds | speed-up | max abs difference |")
        print("|---|---|---|---|")
        print(f"| madmom 0.16.1 | {r['madmom']:.2f} | 1.0x | |")
        print(f"| port (NumPy + numba) | {r['port']:.2f} | {r['madmom'] / r['port']:.1f}x | {r['max_diff']:.1e} |")
        print("\n" + json.dumps(r))


if __name__ == "__main__":
    main()
