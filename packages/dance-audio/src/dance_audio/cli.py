"""``dance features SONG -x NAME ... -o feats.npz [--plot feats.png]``."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from dance_core import DataError

KIND = "feature"


def run_features(args) -> int:
    """Extract the named features of one song at ``args.fps`` and save them (and a plot) atomically."""
    from dance_core import (
        FeatureInputs,
        check_input_file,
        check_output_file,
        get_registry,
        load_audio,
        say,
        write_bytes,
    )

    if args.plot:  # before any work: a missing matplotlib is one line, not a lost extraction
        from .plot import require_plotting

        require_plotting()
    registry = get_registry()
    names = args.extractors or ["librosa-438"]
    for name in names:  # an unknown name fails before the song is decoded
        registry.get(KIND, name)
    if not args.fps > 0:
        raise DataError(f"--fps: must be positive, got {args.fps}")
    check_input_file(args.song, None, "audio file")
    check_output_file(args.out, "-o")
    if args.plot:
        check_output_file(args.plot, "--plot")
    audio = load_audio(Path(args.song), registry)
    n_frames = audio.n_frames(args.fps)
    inputs = FeatureInputs(n_frames=n_frames, audio=audio)
    arrays: dict[str, np.ndarray] = {}
    for name in names:
        extractor = registry.get(KIND, name).build()
        arrays[name] = np.asarray(extractor.extract(inputs, args.fps), dtype=np.float32)
    buf = io.BytesIO()
    np.savez(buf, fps=np.float32(args.fps), **arrays)
    write_bytes(args.out, buf.getvalue())
    shapes = ", ".join(f"{k} {v.shape[1]}" for k, v in arrays.items())
    say(args, f"{args.out}: {n_frames} frames at {args.fps:g} fps ({shapes})")
    if args.plot:
        from .plot import plot_song

        plot_song(audio, args.fps, Path(args.plot))
        say(args, f"{args.plot}: mel spectrogram, onset envelope, beats and downbeats")
    return 0
