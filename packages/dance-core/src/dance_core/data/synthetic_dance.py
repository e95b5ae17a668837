"""The ``synthetic-dance`` dataset and ``dance synth``: synthesized songs with a beat-locked SMPL dancer.

Deterministic from the seed: song ``i`` draws its music from ``(seed, i)`` and dance ``k`` of it its
moves and style from ``(seed, i, k)``, so the same music comes with several dances.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dance_core.data.sources import ClipSource
from dance_core.data.synth_dance import Style, choose_moves, dance
from dance_core.data.synth_music import synthesize
from dance_core.media import Audio
from dance_core.protocols import MotionData


def make_clip(index: int, *, seed: int, seconds: float, bpm: tuple[float, float], rate: int, fps: float,
              dances_per_song: int = 1) -> ClipSource:
    """Clip ``index``: song ``index // dances_per_song`` with dance ``index % dances_per_song``."""
    song_i, dance_i = divmod(index, dances_per_song)
    music_rng = np.random.default_rng([seed, song_i, 0])
    song = synthesize(seconds, float(music_rng.uniform(*bpm)), rate, music_rng)
    dance_rng = np.random.default_rng([seed, song_i, 1, dance_i])
    moves = choose_moves(song.section_bars, dance_rng)
    motion, texts = dance(float(song.beats[0]), 60.0 / song.bpm, moves, seconds, fps, Style.draw(dance_rng))
    name = f"synth-{song_i:04d}" + (f"-{dance_i}" if dances_per_song > 1 else "")
    positions = motion.positions().reshape(motion.n_frames, -1).astype(np.float32)
    channels = [f"{j}.{a}" for j in motion.skeleton.names for a in "xyz"]
    meta = {"bpm": song.bpm, "beats": song.beats.tolist(), "downbeats": song.downbeats.tolist(),
            "sections": song.sections, "style": song.style}
    return ClipSource(name, MotionData(positions, fps, channels, meta, motion), Audio(song.audio, rate),
                      texts=texts, meta=meta)


class SyntheticDance:
    """The ``synthetic-dance`` dataset."""

    def __init__(self, config: Any, fps: float):
        self.config = config
        self.fps = config.motion_fps or fps

    def clip(self, index: int) -> ClipSource:
        """One clip."""
        c = self.config
        return make_clip(index, seed=c.seed, seconds=c.seconds, bpm=tuple(c.bpm), rate=c.sample_rate,
                         fps=self.fps, dances_per_song=c.dances_per_song)

    def clips(self) -> list[ClipSource]:
        """Every song times every dance."""
        return [self.clip(i) for i in range(self.config.songs * self.config.dances_per_song)]


def build(config: Any, *, fps: float, **_: Any) -> SyntheticDance:
    """Build the ``synthetic-dance`` dataset."""
    return SyntheticDance(config, fps)


def write_clip(out: Path, clip: ClipSource) -> list[Path]:
    """Write ``name.wav``, ``name.bvh``, ``name.beats`` (time, beat in bar), ``name.texts`` (start, end,
    sentence) and ``name.sections`` (start, end, section; tempo and style in a comment) into ``out``."""
    from dance_core.atomic import write_text
    from dance_core.components.wav import write_wav
    from dance_core.formats.bvh import BvhFormat

    out.mkdir(parents=True, exist_ok=True)
    base = out / clip.name
    write_wav(base.with_suffix(".wav"), clip.audio.samples, clip.audio.rate)
    BvhFormat(precision=5).write_motion(clip.motion.skeleton_motion, base.with_suffix(".bvh"))
    beats = clip.meta["beats"]
    write_text(base.with_suffix(".beats"), "".join(f"{b:.4f}\t{i % 4 + 1}\n" for i, b in enumerate(beats)))
    write_text(base.with_suffix(".texts"), "".join(f"{t.start:.4f}\t{t.end:.4f}\t{t.text}\n" for t in clip.texts))
    head = f"# bpm {clip.meta['bpm']:.4f} style {clip.meta['style']}\n"
    rows = "".join(f"{a:.4f}\t{b:.4f}\t{n}\n" for n, a, b in clip.meta["sections"])
    write_text(base.with_suffix(".sections"), head + rows)
    return [base.with_suffix(s) for s in (".wav", ".bvh", ".beats", ".texts", ".sections")]


def _write_one(args: tuple) -> str:
    out, index, kwargs = args
    clip = make_clip(index, **kwargs)
    write_clip(Path(out), clip)
    return clip.name


def write_dataset(out: str | Path, songs: int, seed: int = 0, seconds: float = 60.0, fps: float = 60.0,
                  bpm: tuple[float, float] = (80.0, 140.0), rate: int = 22050, dances_per_song: int = 1,
                  jobs: int = 1) -> list[str]:
    """Write a whole synthetic dataset (in ``jobs`` processes); returns the clip names."""
    kwargs = {"seed": seed, "seconds": seconds, "bpm": bpm, "rate": rate, "fps": fps,
              "dances_per_song": dances_per_song}
    work = [(str(out), i, kwargs) for i in range(songs * dances_per_song)]
    if jobs <= 1:
        return [_write_one(w) for w in work]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(jobs) as pool:
        return list(pool.map(_write_one, work, chunksize=4))


def synth_command(args: Any) -> int:
    """``dance synth --out DIR --songs N --seed S``: write a dataset and print where it went."""
    from dance_core.errors import DanceError

    seconds = 60.0 if args.seconds is None else args.seconds
    if not (1 <= args.songs <= 100_000) or not (2.0 <= seconds <= 3600) or args.fps <= 0 or args.rate < 8000:
        raise DanceError("synth: need 1 <= --songs, 2 <= --seconds <= 3600, --fps > 0, --rate >= 8000")
    names = write_dataset(args.out_dir, args.songs, args.seed, seconds, args.fps, rate=args.rate,
                          jobs=max(1, args.jobs))
    print(f"{args.out_dir}: {len(names)} songs ({names[0]} ... {names[-1]}): .wav .bvh .beats .texts .sections")
    return 0
